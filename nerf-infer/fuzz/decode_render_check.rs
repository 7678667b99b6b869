// Shared by the fuzz target (`fuzz_targets/decode_render.rs`) and the
// stable regression test (`nerf-infer/tests/hostile_models.rs`), which
// replays `seeds/` and `regressions/` on every `cargo test`.
use glam::Vec3;
use nerf_infer::format::{crc32, HEADER_LEN};
use nerf_infer::{Camera, Model, Pixel, RayRenderer, RenderOptions, RendererF32, RendererFixed, Scheme};
use nerf_infer::{ScratchF32, ScratchFixed};

fn fix_header(blob: &mut [u8]) {
    if blob.len() < HEADER_LEN {
        return;
    }
    let (head, payload) = blob.split_at_mut(HEADER_LEN);
    head[..4].copy_from_slice(b"NERF");
    head[4..6].copy_from_slice(&1u16.to_le_bytes());
    head[6..10].copy_from_slice(&(payload.len() as u32).to_le_bytes());
    head[10..14].copy_from_slice(&crc32(payload).to_le_bytes());
}

fn rays() -> impl Iterator<Item = (Vec3, Vec3)> {
    let pose = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 4.0]];
    let cam = Camera::from_fov(4, 4, 0.7, pose).unwrap();
    let hostile = [
        (Vec3::NAN, Vec3::Z),
        (Vec3::ZERO, Vec3::ZERO),
        (Vec3::new(0.0, 0.0, 4.0), Vec3::new(0.0, 0.0, f32::NEG_INFINITY)),
        (Vec3::new(0.5, 0.5, 0.5), Vec3::X),
        (Vec3::new(1.0, 0.0, 9.0), Vec3::NEG_Z),
        (Vec3::splat(1e30), Vec3::NEG_ONE),
        (Vec3::new(0.0, 0.0, 4.0), Vec3::new(1e-30, 0.0, -1e-30)),
    ];
    [(1, 1), (2, 2), (0, 3)].into_iter().map(move |(x, y)| cam.ray(x, y)).chain(hostile)
}

/// Colour and opacity in [0, 1]; depth in [near, far] up to rounding (f32
/// summation, and one Q16 step in the fixed path, whose near and far are
/// rounded to Q16).
fn check(p: Pixel, m: &Model<'_>) {
    assert!(p.rgb.iter().chain([&p.opacity]).all(|c| (0.0..=1.0).contains(c)), "{p:?}");
    let (near, far) = (m.scene.near, m.scene.far);
    let slack = 1e-5 * far + if m.scheme() == Scheme::F32 { 0.0 } else { 1.0 / 65536.0 };
    assert!(p.depth.is_finite() && p.depth >= near - slack && p.depth <= far + slack, "{p:?} {:?}", m.scene);
}

/// Decodes `data` (control byte + model file) and renders what it accepts;
/// panics if a pixel is out of range.
pub fn run(data: &[u8]) {
    let Some((&ctl, rest)) = data.split_first() else { return };
    let mut blob = rest.to_vec();
    if ctl & 1 != 0 {
        fix_header(&mut blob);
    }
    let Ok(m) = Model::from_bytes(&blob) else { return };
    let mut opts = RenderOptions::from_model(&m);
    if ctl & 2 != 0 {
        opts.coarse = 2 + (ctl as usize >> 4);
        opts.fine = if m.fine.is_some() { (ctl as usize >> 2) & 3 } else { 0 };
    }
    opts.early_stop = if ctl & 4 != 0 { 0.01 } else { 0.0 };
    opts.seed = (ctl & 8 != 0).then_some(ctl as u32);
    if m.scheme() == Scheme::F32 {
        let Ok(r) = RendererF32::new(&m, opts) else { return };
        let mut s = Box::new(ScratchF32::<3>::default());
        for (k, (o, d)) in rays().enumerate() {
            check(r.render_ray(o, d, (k as u32, 0), &mut s), &m);
        }
    } else {
        let Ok(r) = RendererFixed::new(&m, opts) else { return };
        let mut s = Box::new(ScratchFixed::<3>::default());
        for (k, (o, d)) in rays().enumerate() {
            check(r.render_ray(o, d, (k as u32, 0), &mut s).to_pixel(), &m);
        }
    }
}
