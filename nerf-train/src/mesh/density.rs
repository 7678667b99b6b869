//! The model's density and colour at arbitrary points, through the
//! renderer's own network walk ([`nerf_infer::network::Block`]): f32
//! models on the f32 path, int16 and int8 models on the fixed-point path,
//! so the mesh shows what the renderer draws.

use nerf_infer::fixed::to_fixed;
use nerf_infer::format::{Model, Scheme};
use nerf_infer::network::{Block, LayerKernel, Numbers, F32, W16, W8};
use nerf_infer::unbounded::{contract_f32, contract_q24};
use nerf_infer::Vec3;

/// Samples per network call.
const B: usize = 8;
/// Fractional bits of the fixed-point path's positions (Q24).
const POS_FRAC: u32 = nerf_infer::fixed::NPOS_FRAC;
/// Fractional bits of the fixed-point path's raw density (Q10).
const SIGMA_FRAC: u32 = nerf_infer::fixed::SIGMA_FRAC;

/// The network input of normalised position `u` (the bounds are
/// `[−1, 1]³`): `u` itself, or its contraction for unbounded scenes.
fn net_pos(m: &Model<'_>, u: [f32; 3]) -> [f32; 3] {
    match m.unbounded {
        Some(_) => contract_f32(Vec3::from(u)).to_array(),
        None => u,
    }
}

/// [`net_pos`] in Q24.
fn net_pos_q24(m: &Model<'_>, u: [f32; 3]) -> [i32; 3] {
    let q = u.map(|v| to_fixed(v, POS_FRAC));
    match m.unbounded {
        Some(_) => contract_q24(q.map(i64::from)),
        None => q,
    }
}

/// Whether the occupancy grid (if any) marks the cell of network input `p`
/// occupied: the renderer takes nothing from the other cells.
fn occupied_f32(m: &Model<'_>, p: [f32; 3]) -> bool {
    m.grid.as_ref().is_none_or(|g| g.at_f32(p))
}

/// The density head's raw output (per world unit) at the normalised
/// positions `u`, written to `out` (same length); zero in cells the
/// occupancy grid marks empty. The renderer's density is its positive
/// part, whose level sets above 0 are the same; the raw values keep
/// their slope below 0, so a crossing interpolated between two lattice
/// points lands where the network puts it.
pub fn raw_density(m: &Model<'_>, u: &[[f32; 3]], out: &mut [f32]) {
    match m.scheme() {
        Scheme::F32 => density_with::<F32, F32>(m, u, out, |p| net_pos(m, p), |s| s),
        Scheme::I16 => density_with::<_, W16>(m, u, out, |p| net_pos_q24(m, p), sigma_fixed),
        Scheme::I8 => density_with::<_, W8>(m, u, out, |p| net_pos_q24(m, p), sigma_fixed),
    }
}

/// A raw Q10 density per world unit.
fn sigma_fixed(s: i32) -> f32 {
    s as f32 / (1u32 << SIGMA_FRAC) as f32
}

fn density_with<N: Numbers, K: LayerKernel<N>>(
    m: &Model<'_>,
    u: &[[f32; 3]],
    out: &mut [f32],
    pos: impl Fn([f32; 3]) -> N::Pos,
    sigma: impl Fn(N::Sigma) -> f32,
) {
    let net = m.final_network();
    let mut block = Box::<Block<N, B>>::default();
    let (mut batch, mut at) = ([N::Pos::default(); B], [0usize; B]);
    let mut n = 0;
    let flush = |block: &mut Block<N, B>, batch: &[N::Pos], at: &[usize], out: &mut [f32]| {
        block.eval_density::<K>(m, net, batch, false);
        for (k, &i) in at.iter().enumerate() {
            out[i] = sigma(block.sigma[k]);
        }
    };
    for (i, &p) in u.iter().enumerate() {
        out[i] = 0.0;
        if !occupied_f32(m, net_pos(m, p)) {
            continue;
        }
        (batch[n], at[n]) = (pos(p), i);
        n += 1;
        if n == B {
            flush(&mut block, &batch, &at, out);
            n = 0;
        }
    }
    if n > 0 {
        flush(&mut block, &batch[..n], &at[..n], out);
    }
}

/// Colour (`[0, 1]` per channel) at normalised position `u` seen along
/// the unit world direction `dir`.
pub fn colour(m: &Model<'_>, u: [f32; 3], dir: [f32; 3]) -> [f32; 3] {
    match m.scheme() {
        Scheme::F32 => colour_with::<F32, F32>(m, net_pos(m, u), dir, |c| c),
        Scheme::I16 => colour_with::<_, W16>(m, net_pos_q24(m, u), dir_q24(dir), rgb_fixed),
        Scheme::I8 => colour_with::<_, W8>(m, net_pos_q24(m, u), dir_q24(dir), rgb_fixed),
    }
}

/// A unit direction in Q24, the fixed-point path's ray direction format.
fn dir_q24(d: [f32; 3]) -> [i32; 3] {
    d.map(|v| to_fixed(v, POS_FRAC))
}

/// A Q15 colour as `[0, 1]`.
fn rgb_fixed(c: [u16; 3]) -> [f32; 3] {
    c.map(|v| v as f32 / 32768.0)
}

fn colour_with<N: Numbers, K: LayerKernel<N>>(
    m: &Model<'_>,
    p: N::Pos,
    dir: N::Pos,
    rgb: impl Fn(N::Rgb) -> [f32; 3],
) -> [f32; 3] {
    let net = m.final_network();
    let mut block = Box::<Block<N, 1>>::default();
    block.prepare_ray::<K>(m, net, dir);
    block.eval_density::<K>(m, net, &[p], false);
    block.eval_colour::<K>(m, net, &[0]);
    rgb(block.rgb[0])
}
