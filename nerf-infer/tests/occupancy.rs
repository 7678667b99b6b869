//! Empty-space skipping in the kernel: a grid with every cell occupied
//! changes nothing (bit for bit, both numeric paths), an empty one renders
//! the background without evaluating the network, a half-empty one skips
//! exactly the rays and samples in its clear half, and the coarse level
//! skips no occupied sample. Format: a model with a grid is version 2, one
//! without stays version 1 (int8 exports are version 8 either way). The
//! models are the golden ones (`tests/data/`), rendered by their coarse
//! network alone at 40 samples.
#![cfg(feature = "alloc")]

use nerf_infer::format::owned::OwnedModel;
use nerf_infer::format::{frame, Occupancy, Scheme, MAGIC};
use nerf_infer::sampling::hash32;
use nerf_infer::{
    render_tile, Camera, Error, Model, Pixel, PixelFixed, RenderOptions, RendererF32, RendererFixed, ScratchF32,
    ScratchFixed, Tile,
};

const N: u32 = 16;
/// Stratified samples per ray: every one evaluated without a grid.
const SAMPLES: usize = 40;

/// Looks down −z from z = 4 with a narrow field of view: columns 0..8 see
/// only x < 0 inside the bounds, columns 8..16 only x > 0.
fn camera() -> Camera {
    Camera::from_fov(N, N, 0.3, [[1., 0., 0., 0.], [0., 1., 0., 0.], [0., 0., 1., 4.]]).unwrap()
}

/// The golden f32 model and its int16 and int8 exports.
fn models() -> Vec<OwnedModel> {
    let blobs: [&[u8]; 3] = [
        include_bytes!("data/golden_f32.nerf"),
        include_bytes!("data/golden.nerf"),
        include_bytes!("data/golden8_density.nerf"),
    ];
    blobs.iter().map(|b| OwnedModel::from_model(&Model::from_bytes(b).unwrap())).collect()
}

fn options() -> RenderOptions {
    RenderOptions { coarse: SAMPLES, fine: 0, early_stop: 0.0, seed: None }
}

fn with_grid(m: &OwnedModel, grid: Option<(u16, Vec<u8>)>) -> Vec<u8> {
    OwnedModel { grid, ..m.clone() }.to_bytes().unwrap()
}

/// (pixels as comparable integers, network evaluations) of both paths.
fn render(bytes: &[u8], opts: RenderOptions, cam: &Camera, coarse_skipping: bool) -> (Vec<[u32; 3]>, u64) {
    let m = Model::from_bytes(bytes).unwrap();
    let tile = Tile { x0: 0, y0: 0, width: N, height: N };
    if m.scheme() == Scheme::F32 {
        let r = RendererF32::new(&m, opts).unwrap().with_coarse_skipping(coarse_skipping);
        let (mut s, mut px) = (Box::<ScratchF32<8>>::default(), vec![Pixel::default(); tile.len()]);
        render_tile(&r, cam, tile, &mut *s, &mut px).unwrap();
        (px.iter().map(|p| p.rgb.map(f32::to_bits)).collect(), s.evaluations)
    } else {
        let r = RendererFixed::new(&m, opts).unwrap().with_coarse_skipping(coarse_skipping);
        let (mut s, mut px) = (Box::<ScratchFixed<8>>::default(), vec![PixelFixed::default(); tile.len()]);
        render_tile(&r, cam, tile, &mut *s, &mut px).unwrap();
        (px.iter().map(|p| p.rgb.map(u32::from)).collect(), s.evaluations)
    }
}

fn version(bytes: &[u8]) -> u16 {
    u16::from_le_bytes([bytes[4], bytes[5]])
}

#[test]
fn a_full_grid_changes_nothing_and_an_empty_one_shows_the_background() {
    for m in models() {
        // int8 exports carry 16-bit parts (the density head's: version 8)
        // with or without a grid
        let precise = m.coarse.precise.is_some();
        assert_eq!(precise, m.coarse.scheme == Scheme::I8);
        let plain = with_grid(&m, None);
        assert_eq!(version(&plain), if precise { 8 } else { 1 }, "no grid: still format version 1");
        let (base, evals) = render(&plain, options(), &camera(), true);
        assert_eq!(evals, (N * N) as u64 * SAMPLES as u64);
        let full = with_grid(&m, Some((4, vec![0xFF; 8])));
        assert_eq!(version(&full), if precise { 8 } else { 2 });
        let what = format!("{:?}", m.coarse.scheme);
        assert_eq!(render(&full, options(), &camera(), true), (base.clone(), evals), "{what}: a full grid changed it");
        let (bg, evals) = render(&with_grid(&m, Some((4, vec![0; 8]))), options(), &camera(), true);
        assert_eq!(evals, 0);
        assert!(bg.iter().all(|p| *p == bg[0]));
        assert_ne!(base, bg, "{what}: the model renders only the background");
    }
}

#[test]
fn a_half_grid_skips_the_clear_half_only() {
    for m in models() {
        let (base, all) = render(&with_grid(&m, None), options(), &camera(), true);
        let (bg, _) = render(&with_grid(&m, Some((2, vec![0]))), options(), &camera(), true);
        // cells with x index 1 (x > 0) occupied: bits 1, 3, 5, 7
        let (half, evals) = render(&with_grid(&m, Some((2, vec![0xAA]))), options(), &camera(), true);
        for (k, p) in half.iter().enumerate() {
            let expect = if k as u32 % N >= N / 2 { base[k] } else { bg[k] };
            assert_eq!(*p, expect, "{:?}: pixel {k}", m.coarse.scheme);
        }
        assert_eq!(evals, all / 2);
    }
}

#[test]
fn a_grid_of_the_wrong_size_is_refused() {
    let m = &models()[0];
    let plain = with_grid(m, None);
    assert_eq!(version(&plain), 1);
    for grid in [(4u16, vec![0xFF; 7]), (4, vec![0xFF; 9]), (0, vec![]), (257, vec![0; 2_122_945])] {
        // the payload written by hand (to_bytes would refuse it): version
        // 1's, then the grid version 2 adds
        let mut payload = plain[MAGIC.len() + nerf_infer::format::FRAME_FIELDS_LEN..].to_vec();
        payload.push(1);
        payload.extend(postcard::to_allocvec(&Occupancy { res: grid.0, bits: &grid.1 }).unwrap());
        let bytes = frame(&MAGIC, 2, &payload).unwrap();
        assert_eq!(
            Model::from_bytes(&bytes).unwrap_err(),
            Error::InvalidTopology("occupancy grid resolution or length"),
            "res {}, {} bytes",
            grid.0,
            grid.1.len()
        );
    }
}

/// The coarse level only rules out samples whose cells are all clear: on
/// random grids (resolutions that do and do not divide into coarse cells,
/// sparse to dense), with jitter and early termination, both numeric paths
/// render the same pixels and evaluate the same samples with it as without.
#[test]
fn the_coarse_level_changes_no_pixel_and_skips_no_occupied_sample() {
    let cameras = [
        camera(),
        Camera::from_fov(N, N, 0.9, [[0.6, 0., 0.8, 3.2], [0., 1., 0., 0.4], [-0.8, 0., 0.6, 2.4]]).unwrap(),
    ];
    let opts = RenderOptions { seed: Some(7), early_stop: 0.01, ..options() };
    let mut evaluated = 0;
    for m in models() {
        for (res, per_mille) in [(3u16, 300u32), (16, 20), (37, 100), (64, 8), (64, 150), (200, 2)] {
            let cells = (res as u32).pow(3);
            let mut bits = vec![0u8; cells.div_ceil(8) as usize];
            for i in (0..cells).filter(|&i| hash32(i ^ (res as u32) << 24) % 1000 < per_mille) {
                bits[i as usize / 8] |= 1 << (i % 8);
            }
            let bytes = with_grid(&m, Some((res, bits)));
            for cam in &cameras {
                let on = render(&bytes, opts, cam, true);
                assert_eq!(on, render(&bytes, opts, cam, false), "{:?}, res {res}, {per_mille}‰", m.coarse.scheme);
                evaluated += on.1;
            }
        }
    }
    // the grids leave samples to evaluate, so a lost one would show
    assert!(evaluated > 5_000, "{evaluated} evaluations");
}
