//! Golden vectors: the fixed-point path must reproduce these pixels bit for
//! bit (also on Cortex-M). Regenerate with the workspace's
//! `cargo test --release --test golden -- --ignored bless`.

use nerf_infer::{
    render_tile, use_kernels, Camera, Kernels, Model, PixelFixed, RenderOptions, RendererFixed, ScratchFixed, Tile,
};

#[allow(dead_code)]
mod expected {
    include!("data/golden_expected.rs");
}

const POSE: [[f32; 4]; 3] = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 3.0]];

fn check<const B: usize>(blob: &[u8], want: &[(u16, u16, u16, u16, i32); 256]) {
    let model = Model::from_bytes(blob).unwrap();
    let r = RendererFixed::new(&model, RenderOptions::from_model(&model)).unwrap();
    let cam = Camera::from_fov(16, 16, 0.7, POSE).unwrap();
    let mut px = [PixelFixed::default(); 256];
    let mut scratch = Box::new(ScratchFixed::<B>::default());
    render_tile(&r, &cam, Tile { x0: 0, y0: 0, width: 16, height: 16 }, &mut *scratch, &mut px).unwrap();
    for (k, (p, w)) in px.iter().zip(want).enumerate() {
        let got = (p.rgb[0], p.rgb[1], p.rgb[2], p.opacity, p.depth);
        assert_eq!(got, *w, "pixel {k} (x {}, y {})", k % 16, k / 16);
    }
}

#[test]
fn int16_golden_pixels_are_bit_exact_for_every_block_size() {
    let blob = include_bytes!("data/golden.nerf");
    check::<8>(blob, &expected::GOLDEN16);
    check::<1>(blob, &expected::GOLDEN16);
    check::<3>(blob, &expected::GOLDEN16);
}

#[test]
fn int8_golden_pixels_are_bit_exact() {
    check::<8>(include_bytes!("data/golden8.nerf"), &expected::GOLDEN8);
    check::<2>(include_bytes!("data/golden8.nerf"), &expected::GOLDEN8);
}

/// An int8 model with the 16-bit parts of format version 6 (the view
/// layer's direction rows, the colour head).
#[test]
fn int8_golden_pixels_with_16_bit_parts_are_bit_exact() {
    let blob = include_bytes!("data/golden8_precise.nerf");
    assert_eq!(u16::from_le_bytes([blob[4], blob[5]]), 6);
    check::<8>(blob, &expected::GOLDEN8_PRECISE);
    check::<1>(blob, &expected::GOLDEN8_PRECISE);
    // and they change pixels: the model without them renders others
    assert_ne!(expected::GOLDEN8_PRECISE, expected::GOLDEN8);
}

/// An int8 model with the 16-bit density head of format version 8 beside
/// the parts of version 6: what `nerf export --bits 8` writes.
#[test]
fn int8_golden_pixels_with_a_16_bit_density_head_are_bit_exact() {
    let blob = include_bytes!("data/golden8_density.nerf");
    assert_eq!(u16::from_le_bytes([blob[4], blob[5]]), 8);
    check::<8>(blob, &expected::GOLDEN8_DENSITY);
    check::<1>(blob, &expected::GOLDEN8_DENSITY);
    check::<3>(blob, &expected::GOLDEN8_DENSITY);
    assert_ne!(expected::GOLDEN8_DENSITY, expected::GOLDEN8_PRECISE);
}

/// An int8 model with a proposal grid (format version 11): the network is
/// evaluated only at the samples the grid places.
#[test]
fn int8_golden_pixels_with_a_proposal_grid_are_bit_exact() {
    let blob = include_bytes!("data/golden8_proposal.nerf");
    assert_eq!(u16::from_le_bytes([blob[4], blob[5]]), 11);
    check::<8>(blob, &expected::GOLDEN8_PROPOSAL);
    check::<1>(blob, &expected::GOLDEN8_PROPOSAL);
    check::<3>(blob, &expected::GOLDEN8_PROPOSAL);
    // the grid's placement shows: some pixels are opaque, some clear
    let opacity = |k: usize| expected::GOLDEN8_PROPOSAL[k].3;
    assert!((0..256).any(|k| opacity(k) > 30000) && (0..256).any(|k| opacity(k) < 3000));
}

/// The SIMD kernels give the portable references' bits: every set this
/// build carries and this CPU runs renders every golden model's pixels
/// (the int8 layer, its requantiser, the sine and the feature lookups all
/// run in these renders). The only test here that changes the kernels;
/// the others, if they run meanwhile, render the same pixels with them.
#[test]
fn golden_pixels_are_the_same_with_every_kernel_set() {
    let mut ran = Vec::new();
    for k in Kernels::ALL {
        if !use_kernels(k) {
            continue;
        }
        ran.push(k);
        check::<8>(include_bytes!("data/golden.nerf"), &expected::GOLDEN16);
        check::<8>(include_bytes!("data/golden8.nerf"), &expected::GOLDEN8);
        check::<8>(include_bytes!("data/golden8_precise.nerf"), &expected::GOLDEN8_PRECISE);
        check::<8>(include_bytes!("data/golden8_density.nerf"), &expected::GOLDEN8_DENSITY);
        check::<3>(include_bytes!("data/golden8_proposal.nerf"), &expected::GOLDEN8_PROPOSAL);
    }
    assert!(use_kernels(Kernels::best()));
    eprintln!("kernel sets checked: {ran:?}");
    assert!(ran.contains(&Kernels::Portable) && ran.contains(&Kernels::best()));
}

fn render_with<const B: usize>(blob: &[u8], early_stop: f32) -> [PixelFixed; 256] {
    let model = Model::from_bytes(blob).unwrap();
    let opts = RenderOptions { early_stop, ..RenderOptions::from_model(&model) };
    let r = RendererFixed::new(&model, opts).unwrap();
    let cam = Camera::from_fov(16, 16, 0.7, POSE).unwrap();
    let mut px = [PixelFixed::default(); 256];
    let mut scratch = Box::new(ScratchFixed::<B>::default());
    render_tile(&r, &cam, Tile { x0: 0, y0: 0, width: 16, height: 16 }, &mut *scratch, &mut px).unwrap();
    px
}

/// Early termination is decided before every sample, not per block, so a
/// firmware build with one-sample blocks renders what the host renders.
#[test]
fn early_termination_does_not_depend_on_the_block_size() {
    let blobs = [
        &include_bytes!("data/golden.nerf")[..],
        include_bytes!("data/golden8.nerf"),
        include_bytes!("data/golden8_precise.nerf"),
        include_bytes!("data/golden8_density.nerf"),
    ];
    for blob in blobs {
        let one = render_with::<1>(blob, 0.05);
        assert_eq!(one, render_with::<3>(blob, 0.05));
        assert_eq!(one, render_with::<8>(blob, 0.05));
        // and it did stop rays early: some pixel differs from the full render
        assert_ne!(one, render_with::<8>(blob, 0.0));
    }
}

#[test]
fn golden_pixels_are_not_trivial() {
    // a golden image of one flat colour would test little
    let px = &expected::GOLDEN16;
    let min = px.iter().map(|p| p.0).min().unwrap();
    let max = px.iter().map(|p| p.0).max().unwrap();
    let opaque = px.iter().filter(|p| p.3 > 16384).count();
    assert!(max - min > 3000, "red channel spans only {min}..{max}");
    assert!(opaque > 20 && opaque < 250, "{opaque} pixels over half opaque");
}
