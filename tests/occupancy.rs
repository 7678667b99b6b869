//! Empty-space skipping in the kernel: a grid with every cell occupied
//! changes nothing (bit for bit, both numeric paths), an empty one renders
//! the background without evaluating the network, and a half-empty one
//! skips exactly the rays and samples in its clear half. Format: a model
//! with a grid is version 2, one without stays version 1.

mod support;

use nerf_infer::format::Scheme;
use nerf_infer::{
    render_tile, Camera, Error, Model, PixelFixed, RenderOptions, RendererF32, RendererFixed, ScratchF32, ScratchFixed,
    Tile,
};
use nerf_train::config::TrainConfig;
use nerf_train::export::{quantise, random_model, OwnedModel};
use support::*;

const N: u32 = 16;

/// Looks down −z from z = 4 with a narrow field of view: columns 0..8 see
/// only x < 0 inside the bounds, columns 8..16 only x > 0.
fn camera() -> Camera {
    Camera::from_fov(N, N, 0.3, [[1., 0., 0., 0.], [0., 1., 0., 0.], [0., 0., 1., 4.]]).unwrap()
}

fn with_grid(m: &OwnedModel, grid: Option<(u16, Vec<u8>)>) -> Vec<u8> {
    OwnedModel { grid, ..m.clone() }.to_bytes().unwrap()
}

/// (pixels as comparable integers, network evaluations) of both paths.
fn render(bytes: &[u8]) -> (Vec<[u32; 3]>, u64) {
    let m = Model::from_bytes(bytes).unwrap();
    let opts = RenderOptions::from_model(&m);
    let tile = Tile { x0: 0, y0: 0, width: N, height: N };
    if m.scheme() == Scheme::F32 {
        let r = RendererF32::new(&m, opts).unwrap();
        let mut s: ScratchF32 = ScratchF32::default();
        let mut px = vec![Default::default(); tile.len()];
        render_tile(&r, &camera(), tile, &mut s, &mut px).unwrap();
        (px.iter().map(|p: &nerf_infer::Pixel| p.rgb.map(f32::to_bits)).collect(), s.evaluations)
    } else {
        let r = RendererFixed::new(&m, opts).unwrap();
        let mut s: ScratchFixed = ScratchFixed::default();
        let mut px = vec![Default::default(); tile.len()];
        render_tile(&r, &camera(), tile, &mut s, &mut px).unwrap();
        (px.iter().map(|p: &nerf_infer::PixelFixed| p.rgb.map(|c| c as u32)).collect(), s.evaluations)
    }
}

fn models() -> Vec<OwnedModel> {
    let cfg = TrainConfig { n_fine: 0, n_coarse: 40, ..small_config() };
    let f = random_model(&cfg, unit_scene(), 3, 6.0);
    let fb = f.to_bytes().unwrap();
    let m = Model::from_bytes(&fb).unwrap();
    vec![f.clone(), quantise(&m, Scheme::I16).unwrap(), quantise(&m, Scheme::I8).unwrap()]
}

#[test]
fn a_full_grid_changes_nothing_and_an_empty_one_shows_the_background() {
    for m in models() {
        // int8 exports carry 16-bit parts (the density head's: version 8)
        // with or without a grid
        let precise = m.coarse.precise.is_some();
        assert_eq!(precise, m.coarse.scheme == Scheme::I8);
        let plain = with_grid(&m, None);
        let plain_version = if precise { 8 } else { 1 };
        assert_eq!(u16::from_le_bytes([plain[4], plain[5]]), plain_version, "no grid: still format version 1");
        let (base, evals) = render(&plain);
        assert_eq!(evals, (N * N) as u64 * 40);
        let full = with_grid(&m, Some((4, vec![0xFF; 8])));
        assert_eq!(u16::from_le_bytes([full[4], full[5]]), if precise { 8 } else { 2 });
        assert_eq!(render(&full), (base.clone(), evals), "{:?}: a full grid changed the render", m.coarse.scheme);
        let (bg, evals) = render(&with_grid(&m, Some((4, vec![0; 8]))));
        assert_eq!(evals, 0);
        let white = bg[0];
        assert!(bg.iter().all(|p| *p == white));
        assert_ne!(base, bg);
    }
}

#[test]
fn a_half_grid_skips_the_clear_half_only() {
    for m in models() {
        let (base, all) = render(&with_grid(&m, None));
        let (bg, _) = render(&with_grid(&m, Some((2, vec![0]))));
        // cells with x index 1 (x > 0) occupied: bits 1, 3, 5, 7
        let (half, evals) = render(&with_grid(&m, Some((2, vec![0xAA]))));
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
    for grid in [(4u16, vec![0xFF; 7]), (4, vec![0xFF; 9]), (0, vec![]), (257, vec![0; 2_122_945])] {
        let mut bytes = OwnedModel { grid: None, ..m.clone() }.to_bytes().unwrap();
        // write the payload by hand: validation in to_bytes would refuse it
        let payload_len = u32::from_le_bytes(bytes[6..10].try_into().unwrap()) as usize;
        let mut payload = bytes.split_off(14);
        assert_eq!(payload.len(), payload_len);
        payload.push(1);
        payload.extend(postcard::to_stdvec(&nerf_infer::format::Occupancy { res: grid.0, bits: &grid.1 }).unwrap());
        bytes[4..6].copy_from_slice(&2u16.to_le_bytes());
        bytes[6..10].copy_from_slice(&(payload.len() as u32).to_le_bytes());
        bytes[10..14].copy_from_slice(&nerf_infer::format::crc32(&payload).to_le_bytes());
        bytes.extend(payload);
        assert_eq!(
            Model::from_bytes(&bytes).unwrap_err(),
            Error::InvalidTopology("occupancy grid resolution or length"),
            "res {}, {} bytes",
            grid.0,
            grid.1.len()
        );
    }
}

#[test]
fn a_coarsened_grid_keeps_every_occupied_point() {
    let mut m = models().remove(0);
    // a sparse random 16³ grid
    let bits: Vec<u8> = (0..512u32).map(|i| nerf_infer::sampling::hash32(i).is_multiple_of(16) as u8).collect();
    m.grid = Some((16, bits));
    let fine = m.clone();
    nerf_train::export::coarsen_grid(&mut m, 4).unwrap();
    assert_eq!(m.grid.as_ref().unwrap().1.len(), 8);
    assert!(nerf_train::export::coarsen_grid(&mut m.clone(), 3).is_err());
    let (f, c) = (fine.grid.as_ref().unwrap(), m.grid.as_ref().unwrap());
    let (f, c) = (
        nerf_infer::format::Occupancy { res: f.0, bits: &f.1 },
        nerf_infer::format::Occupancy { res: c.0, bits: &c.1 },
    );
    let mut both = 0;
    for k in 0..20_000u32 {
        let h = |j: u32| (nerf_infer::sampling::hash32(k * 3 + j) >> 8) as f32 / (1 << 23) as f32 - 1.0;
        let p = [h(0), h(1), h(2)];
        if f.at_f32(p) {
            assert!(c.at_f32(p), "{p:?} occupied in the fine grid, clear in the coarse one");
            both += 1;
        }
    }
    assert!(both > 50 && c.occupied_cells() < 40, "{both} {}", c.occupied_cells());
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
    let tile = Tile { x0: 0, y0: 0, width: N, height: N };
    let mut evaluated = 0;
    for (k, m) in models().into_iter().enumerate() {
        for (res, per_mille) in [(3u16, 300u32), (16, 20), (37, 100), (64, 8), (64, 150), (200, 2)] {
            let cells = (res as u32).pow(3);
            let mut bits = vec![0u8; cells.div_ceil(8) as usize];
            for i in (0..cells).filter(|&i| nerf_infer::sampling::hash32(i ^ (res as u32) << 24) % 1000 < per_mille) {
                bits[i as usize / 8] |= 1 << (i % 8);
            }
            let bytes = with_grid(&m, Some((res, bits)));
            let model = Model::from_bytes(&bytes).unwrap();
            let opts = RenderOptions { seed: Some(7), early_stop: 0.01, ..RenderOptions::from_model(&model) };
            for cam in &cameras {
                let what = format!("{:?}, res {res}, {per_mille}‰", m.coarse.scheme);
                if k == 0 {
                    let r = RendererF32::new(&model, opts).unwrap();
                    let run = |r: &RendererF32| {
                        let (mut s, mut px) =
                            (ScratchF32::<8>::default(), vec![nerf_infer::Pixel::default(); tile.len()]);
                        render_tile(r, cam, tile, &mut s, &mut px).unwrap();
                        (px.iter().map(|p| p.rgb.map(f32::to_bits)).collect::<Vec<_>>(), s.evaluations)
                    };
                    let (on, off) = (run(&r), run(&r.with_coarse_skipping(false)));
                    assert_eq!(on, off, "{what}");
                    evaluated += on.1;
                } else {
                    let r = RendererFixed::new(&model, opts).unwrap();
                    let run = |r: &RendererFixed| {
                        let (mut s, mut px) = (ScratchFixed::<8>::default(), vec![PixelFixed::default(); tile.len()]);
                        render_tile(r, cam, tile, &mut s, &mut px).unwrap();
                        (px, s.evaluations)
                    };
                    let (on, off) = (run(&r), run(&r.with_coarse_skipping(false)));
                    assert_eq!(on, off, "{what}");
                    evaluated += on.1;
                }
            }
        }
    }
    // the grids leave samples to evaluate, so a lost one would show
    assert!(evaluated > 5_000, "{evaluated} evaluations");
}
