//! The march's capacity: a one-pass model marches up to
//! [`MAX_MARCH`](nerf_infer::format::MAX_MARCH) samples (every one
//! evaluated, in both numeric paths, and the paths agree), a two-pass
//! model's coarse pass at most [`MAX_COARSE`](nerf_infer::format::MAX_COARSE);
//! more is refused by the renderers and by the model writer. The models are
//! the golden f32 one and its int16 export (`tests/data/`).
#![cfg(feature = "alloc")]

use nerf_infer::format::owned::OwnedModel;
use nerf_infer::format::{MAX_COARSE, MAX_MARCH};
use nerf_infer::{
    Error, Model, Orbit, RayRenderer, RenderOptions, RendererF32, RendererFixed, ScratchF32, ScratchFixed,
};

const F32: &[u8] = include_bytes!("data/golden_f32.nerf");
const I16: &[u8] = include_bytes!("data/golden.nerf");

/// `blob`'s coarse network alone, marching `MAX_MARCH` samples.
fn longest_one_pass(blob: &[u8]) -> Vec<u8> {
    let mut m = OwnedModel::from_model(&Model::from_bytes(blob).unwrap());
    m.fine = None;
    m.samples.coarse = MAX_MARCH as u16;
    m.samples.fine = 0;
    m.to_bytes().unwrap()
}

#[test]
fn one_pass_models_march_up_to_1024_samples_and_two_pass_models_256() {
    let (f, q16) = (longest_one_pass(F32), longest_one_pass(I16));
    let (mf, mq) = (Model::from_bytes(&f).unwrap(), Model::from_bytes(&q16).unwrap());
    assert_eq!((mf.samples.coarse, mf.samples.fine), (MAX_MARCH as u16, 0));
    // every sample of the longest march is evaluated, in both paths, and they agree
    let opts = RenderOptions { early_stop: 0.0, ..RenderOptions::from_model(&mf) };
    let rf = RendererF32::new(&mf, opts).unwrap();
    let rq = RendererFixed::new(&mq, opts).unwrap();
    let (mut sf, mut sq) = (Box::<ScratchF32>::default(), Box::<ScratchFixed>::default());
    let cam = Orbit::new(&mf.scene, None).camera(0.3, 8, 8).unwrap();
    let (mut worst, mut marched) = (0.0f32, 0);
    for (x, y) in (0..8).flat_map(|y| (0..8).map(move |x| (x, y))) {
        let (o, d) = cam.ray(x, y);
        let before = (sf.evaluations, sq.evaluations);
        let a = rf.render_ray(o, d, (x, y), &mut sf);
        let b = rq.render_ray(o, d, (x, y), &mut sq).to_pixel();
        worst = (0..3).fold(worst, |w, c| w.max((a.rgb[c] - b.rgb[c]).abs()));
        // a ray that meets the bounds evaluates every sample (no grid, no
        // early termination); one that misses them, none
        let n = (sf.evaluations - before.0, sq.evaluations - before.1);
        assert!(n == (0, 0) || n == (MAX_MARCH as u64, MAX_MARCH as u64), "pixel ({x}, {y}): {n:?}");
        marched += (n.0 > 0) as u32;
    }
    println!("{marched} of 64 rays marched; worst |Δrgb| int16 against f32 {worst}");
    assert!(marched >= 32, "{marched} of 64 rays met the bounds");
    assert!(worst < 0.02, "worst |Δrgb| {worst}");
    let mut o = RenderOptions::from_model(&mf);
    o.coarse = MAX_MARCH + 1;
    assert_eq!(RendererF32::new(&mf, o).unwrap_err(), Error::InvalidSamples);
    // with a fine pass the coarse samples stop at 256: in the renderer's
    // options and the model writer
    let m2 = Model::from_bytes(F32).unwrap();
    assert!(m2.fine.is_some());
    let mut o = RenderOptions::from_model(&m2);
    o.coarse = MAX_COARSE + 1;
    assert_eq!(RendererF32::new(&m2, o).unwrap_err(), Error::InvalidSamples);
    o.fine = 0; // the coarse network alone is one pass
    RendererF32::new(&m2, o).unwrap();
    let mut owned = OwnedModel::from_model(&m2);
    owned.samples.coarse = MAX_COARSE as u16 + 1;
    assert_eq!(owned.to_bytes().unwrap_err(), Error::InvalidSamples);
}
