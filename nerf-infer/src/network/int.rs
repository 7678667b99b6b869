//! The network in fixed point: i16 activations, integer weights
//! accumulated exactly (int16 in i64, int8 in i32), requantised per output
//! channel to the next layer's scale. The dense kernels are those
//! [`crate::arch`] picks for the build ([`IntKernel`]).

use super::contract::{Act, Fixed, Inputs, LayerKernel, Numbers, ENC_MAX};
use crate::arch::IntKernel;
use crate::encoding::encode_fixed;
use crate::error::{Error, Result};
use crate::fixed::{sat_i32, sigmoid_q12_q15};
use crate::format::{read_i16, read_i32, sigma_layer, Layer, Model, Network, PreciseNet, Scheme};
use crate::layer::{Input, TILE_C};
use crate::limits::FOOTPRINT_POINTS;
use crate::limits::MAX_WIDTH;
use crate::tensor::Zero;

/// The accumulators of a fixed-point block: i64 rows for int16 weights,
/// i32 rows for int8 weights ([`IntWeight::pick`](crate::layer::IntWeight::pick) chooses), and the
/// per-ray start of the view layer's sums.
#[derive(Clone)]
pub struct FixedAcc<const B: usize> {
    a64: [[i64; MAX_WIDTH]; B],
    a32: [[i32; MAX_WIDTH]; B],
    view: [i64; MAX_WIDTH],
}

impl<const B: usize> Default for FixedAcc<B> {
    fn default() -> Self {
        Self::ZERO
    }
}

impl<const B: usize> Zero for FixedAcc<B> {
    const ZERO: Self = Self { a64: [[0; MAX_WIDTH]; B], a32: [[0; MAX_WIDTH]; B], view: [0; MAX_WIDTH] };
}

impl Numbers for Fixed {
    type X = i16;
    type Pos = [i32; 3];
    type Sigma = i32;
    type Rgb = [u16; 3];
    type Acc<const B: usize> = FixedAcc<B>;

    fn encode_rows(
        model: &Model<'_>,
        pos: &[[i32; 3]],
        foot: Option<&[[[i32; 3]; FOOTPRINT_POINTS]]>,
        enc: &mut [[i16; ENC_MAX]],
    ) -> usize {
        let e = &model.encoding;
        let mut pd = 0;
        for (s, p) in pos.iter().enumerate() {
            pd = encode_fixed(*p, e.pos_freqs as usize, e.include_input, e.raw_frac_bits as u32, &mut enc[s]);
        }
        #[cfg(feature = "feature-grid")]
        if let Some(f) = &model.features {
            match foot {
                Some(ft) => crate::arch::feature_rows_mean(f, ft, enc, pd),
                None => crate::arch::feature_rows(f, pos, enc, pd),
            }
            pd += f.dim();
        }
        #[cfg(not(feature = "feature-grid"))]
        let _ = foot;
        pd
    }

    fn encode_dir(model: &Model<'_>, dir: [i32; 3], out: &mut [i16; ENC_MAX]) -> usize {
        let e = &model.encoding;
        encode_fixed(dir, e.dir_freqs as usize, e.include_input, e.raw_frac_bits as u32, out)
    }
}

/// int16 and int8 weights.
impl<W: IntKernel> LayerKernel<Fixed> for W {
    fn dense<const B: usize>(
        net: &Network<'_>,
        l: &Layer<'_>,
        view: bool,
        inputs: Inputs<'_, i16, MAX_WIDTH>,
        n: usize,
        acc: &mut FixedAcc<B>,
        out: &mut [[i16; MAX_WIDTH]],
        act: Act,
    ) {
        let FixedAcc { a64, a32, view: v } = acc;
        let acc = W::pick(a64, a32);
        init_int::<W>(l, view.then_some(&*v), n, acc);
        let mut row0 = 0;
        if let Some((enc, pd)) = inputs.enc {
            accumulate_int::<W, ENC_MAX>(l, Input { rows: enc, row0: 0, width: pd, n }, acc);
            row0 = pd;
        }
        if let Some((prev, w)) = inputs.prev {
            accumulate_int::<W, MAX_WIDTH>(l, Input { rows: prev, row0, width: w, n }, acc);
        }
        let bounds = match act {
            Act::Relu => relu_bounds(net),
            Act::Linear => linear_bounds(net),
        };
        W::requant_rows(l, n, acc, out, bounds);
    }

    fn sigma_head<const B: usize>(
        l: &Layer<'_>,
        head16: Option<&Layer<'_>>,
        trunk: &[[i16; MAX_WIDTH]],
        w: usize,
        n: usize,
        acc: &mut FixedAcc<B>,
        sigma: &mut [i32; B],
    ) {
        if let Some(l16) = head16 {
            return sigma16(l16, &trunk[..n], w, &mut sigma[..n]);
        }
        let acc = W::pick(&mut acc.a64, &mut acc.a32);
        init_int::<W>(l, None, n, acc);
        accumulate_int::<W, MAX_WIDTH>(l, Input { rows: trunk, row0: 0, width: w, n }, acc);
        let r = l.requant(0);
        for s in 0..n {
            sigma[s] = sat_i32(r.apply(acc[s][0].into()));
        }
    }

    fn rgb_head<const B: usize>(
        l: &Layer<'_>,
        head16: Option<&Layer<'_>>,
        input: &[[i16; MAX_WIDTH]],
        dim: usize,
        n: usize,
        acc: &mut FixedAcc<B>,
        rgb: &mut [[u16; 3]; B],
    ) {
        let mut sums = [[0i64; 3]; B];
        let head = match head16 {
            Some(l16) => {
                head16_sums(l16, &input[..n], dim, &mut sums);
                l16
            }
            None => {
                let acc = W::pick(&mut acc.a64, &mut acc.a32);
                init_int::<W>(l, None, n, acc);
                accumulate_int::<W, MAX_WIDTH>(l, Input { rows: input, row0: 0, width: dim, n }, acc);
                for (s, a) in sums.iter_mut().zip(acc.iter()) {
                    *s = [a[0].into(), a[1].into(), a[2].into()];
                }
                l
            }
        };
        rgb_from_sums(head, &sums[..n], rgb);
    }

    fn fold_view<const B: usize>(
        l: &Layer<'_>,
        rows16: &[u8],
        dir: &[i16; ENC_MAX],
        nd: usize,
        w: usize,
        acc: &mut FixedAcc<B>,
    ) {
        let od = l.out_dim as usize;
        let FixedAcc { a64, a32, view } = acc;
        if !rows16.is_empty() {
            return fold_rows16(l, rows16, &dir[..nd], view);
        }
        if cfg!(target_arch = "x86_64") {
            // the layer kernel on one sample, rows w.. (the SIMD one where
            // built; kept off the Cortex-M for flash)
            let acc = W::pick(a64, a32);
            init_int::<W>(l, None, 1, acc);
            accumulate_int::<W, ENC_MAX>(l, Input { rows: core::slice::from_ref(dir), row0: w, width: nd, n: 1 }, acc);
            for (v, &a) in view[..od].iter_mut().zip(&acc[0][..od]) {
                *v = a.into();
            }
            return;
        }
        for c in 0..od {
            let mut acc: W::A = W::from_i64(read_i32(l.bias, c) as i64);
            for (j, &a) in dir[..nd].iter().enumerate() {
                let k = ((w + j) * od + c) * W::BYTES;
                acc += W::mul(a, &l.weights[k..k + W::BYTES]);
            }
            view[c] = acc.into();
        }
    }
}

/// `view[c] = bias[c] + round(Σ_j dir[j] · rows16[j][c] / 2^SHIFT)`: the
/// direction's part of view layer `l` from its 16-bit rows (format 6). One
/// copy for both weight widths (a Cortex-M's flash); the outputs are
/// contiguous, so the sums vectorise.
#[inline(never)]
fn fold_rows16(l: &Layer<'_>, rows16: &[u8], dir: &[i16], view: &mut [i64; MAX_WIDTH]) {
    let od = l.out_dim as usize;
    let sums = &mut view[..od];
    sums.fill(0);
    for (&x, row) in dir.iter().zip(rows16.chunks_exact(2 * od)) {
        for (a, w) in sums.iter_mut().zip(row.chunks_exact(2)) {
            // an i16 · i16 product fits i32 (at most 2³⁰)
            *a += (x as i32 * i16::from_le_bytes([w[0], w[1]]) as i32) as i64;
        }
    }
    let half = 1i64 << (PreciseNet::SHIFT - 1);
    for (c, v) in sums.iter_mut().enumerate() {
        *v = read_i32(l.bias, c) as i64 + ((*v + half) >> PreciseNet::SHIFT);
    }
}

/// `sigma[s]`: the 16-bit density head `l` (format 8) on the first `w`
/// values of each trunk row, `bias + Σ_j x[j]·w[j]` in i64 requantised
/// to Q10. A plain loop out of line, as [`head16_sums`].
#[inline(never)]
fn sigma16(l: &Layer<'_>, trunk: &[[i16; MAX_WIDTH]], w: usize, sigma: &mut [i32]) {
    let (bias, r) = (read_i32(l.bias, 0) as i64, l.requant(0));
    for (x, s) in trunk.iter().zip(sigma.iter_mut()) {
        let mut acc = bias;
        for (&v, wt) in x[..w].iter().zip(l.weights.chunks_exact(2)) {
            // an i16 · i16 product fits i32 (at most 2³⁰)
            acc += (v as i32 * i16::from_le_bytes([wt[0], wt[1]]) as i32) as i64;
        }
        *s = sat_i32(r.apply(acc));
    }
}

/// The colour head's sums of an int8 model's 16-bit head (format 6) on
/// the first `dim` values of each input row: `bias[c] + Σ_j x[j]·w[j][c]`
/// in i64, the three outputs in one pass over the weights. A plain loop
/// out of line (the int16 kernel inlined into the int8 path would cost a
/// Cortex-M 4 KiB of flash).
#[inline(never)]
fn head16_sums(l: &Layer<'_>, input: &[[i16; MAX_WIDTH]], dim: usize, sums: &mut [[i64; 3]]) {
    for (x, acc) in input.iter().zip(sums.iter_mut()) {
        *acc = [0, 1, 2].map(|c| read_i32(l.bias, c) as i64);
        for (&v, w) in x[..dim].iter().zip(l.weights.chunks_exact(6)) {
            for (c, a) in acc.iter_mut().enumerate() {
                // an i16 · i16 product fits i32 (at most 2³⁰)
                *a += (v as i32 * i16::from_le_bytes([w[2 * c], w[2 * c + 1]]) as i32) as i64;
            }
        }
    }
}

/// The colour of each sample from its colour-head sums: requantised to a
/// Q12 logit, then the sigmoid (Q15).
fn rgb_from_sums(l: &Layer<'_>, sums: &[[i64; 3]], rgb: &mut [[u16; 3]]) {
    for c in 0..3 {
        let r = l.requant(c);
        for (s, out) in sums.iter().zip(rgb.iter_mut()) {
            out[c] = colour_q15(r, s[c]);
        }
    }
}

/// One colour channel: `sum` requantised by `r`, then the sigmoid. Out of
/// line: a loop over three channels would otherwise hold three copies (a
/// Cortex-M's flash), and a division dominates its time anyway.
#[inline(never)]
fn colour_q15(r: crate::fixed::Requant, sum: i64) -> u16 {
    sigmoid_q12_q15(sat_i32(r.apply(sum)))
}

/// Checks that no int8 layer of `net` (a network of `model`) can overflow
/// its i32 accumulator: `Σⱼ |W[j][c]| · 32768 + |bias[c]| ≤ i32::MAX` for
/// every output `c`, the view layer's 16-bit direction rows (when the
/// model has them) counting `|w16| · 2^(15 − SHIFT)` each and 1 for their
/// rounding.
pub fn check_i8_headroom(model: &Model<'_>, net: &Network<'_>) -> Result<()> {
    if net.scheme != Scheme::I8 {
        return Ok(());
    }
    let t = &model.topology;
    let nd = model.encoding.dir_dim();
    for (i, l) in net.layers.iter().enumerate() {
        let od = l.out_dim as usize;
        let din = l.in_dim as usize;
        let rows16 = net.precise.map_or(&[][..], |p| p.view_dirs);
        let rows16 = (t.view_dependent && i == sigma_layer(t) + 2 && !rows16.is_empty()).then_some(rows16);
        let narrow = if rows16.is_some() { din - nd } else { din };
        for c in 0..od {
            let mut sum = (read_i32(l.bias, c) as i64).abs();
            for j in 0..narrow {
                sum += ((l.weights[j * od + c] as i8 as i64).abs()) << 15;
            }
            if let Some(rows16) = rows16 {
                for j in 0..nd {
                    let w = read_i16(rows16, j * od + c) as i64;
                    sum += w.abs() << (15 - PreciseNet::SHIFT);
                }
                sum += 1;
            }
            if sum > i32::MAX as i64 {
                return Err(Error::InvalidScale(i as u8));
            }
        }
    }
    Ok(())
}

/// `acc[s][c] += Σ_j input[s][j] · W[row0 + j][c]` (integer weights, exact).
#[inline]
fn accumulate_int<W: IntKernel, const N: usize>(l: &Layer<'_>, x: Input<'_, i16, N>, acc: &mut [[W::A; MAX_WIDTH]]) {
    let Input { rows: input, row0, width: in_dim, n } = x;
    let od = l.out_dim as usize;
    // x86 only: on a Cortex-M the unrolled loop costs 6 KiB of flash for 1 %
    // fewer instructions
    if od == 1 && cfg!(target_arch = "x86_64") {
        // the density head: contiguous weights, a dot product that vectorises
        let w = &l.weights[row0 * W::BYTES..(row0 + in_dim) * W::BYTES];
        for (x, a) in input[..n].iter().zip(acc.iter_mut()) {
            let mut sum = W::A::default();
            for (&x, w) in x[..in_dim].iter().zip(w.chunks_exact(W::BYTES)) {
                sum += W::mul(x, w);
            }
            a[0] += sum;
        }
        return;
    }
    if od < TILE_C && !W::wide_takes_narrow() {
        // the colour head: one dot product per output
        for (x, a) in input[..n].iter().zip(acc.iter_mut()) {
            for c in 0..od {
                let mut sum = W::A::default();
                for j in 0..in_dim {
                    let k = ((row0 + j) * od + c) * W::BYTES;
                    sum += W::mul(x[j], &l.weights[k..k + W::BYTES]);
                }
                a[c] += sum;
            }
        }
        return;
    }
    W::accumulate_wide(l, x, acc);
}

/// `acc[s][c] = bias[c]`, or the per-ray view accumulator when given.
fn init_int<W: IntKernel>(l: &Layer<'_>, view: Option<&[i64; MAX_WIDTH]>, n: usize, acc: &mut [[W::A; MAX_WIDTH]]) {
    let od = l.out_dim as usize;
    let Some((first, rest)) = acc[..n].split_first_mut() else {
        return;
    };
    for (c, y) in first[..od].iter_mut().enumerate() {
        *y = match view {
            // prepare_ray summed a subset of this channel's checked terms.
            Some(v) => W::from_i64(v[c]),
            None => W::from_i64(read_i32(l.bias, c) as i64),
        };
    }
    // the other samples start from the same row (a block copy)
    for row in rest {
        row[..od].copy_from_slice(&first[..od]);
    }
}

/// The linear feature layer's saturation: i16, or i8 when the network
/// says so.
fn linear_bounds(net: &Network<'_>) -> (i16, i16) {
    if net.act_bits == 8 {
        (-127, 127)
    } else {
        (i16::MIN, i16::MAX)
    }
}

/// The ReLU of hidden activations: i16, or u8 when the network says so.
fn relu_bounds(net: &Network<'_>) -> (i16, i16) {
    (0, if net.act_bits == 8 { 255 } else { i16::MAX })
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::layer::{W16, W8};

    /// The dispatching integer kernel (VNNI or AVX2 where built, heads as dot
    /// products) against the plain triple loop, over the shapes the format
    /// allows: odd and even inputs, narrow and wide outputs, short tiles.
    fn check_against_naive<W: IntKernel>() {
        let mut h = 0x9e37_79b9u32;
        let mut next = move || {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            h
        };
        for &in_dim in &[1usize, 2, 51, 64, 79, 255, 256] {
            for &od in &[1usize, 3, 7, 32, 40, 45, 48, 64, 255, 256] {
                for &n in &[1usize, 3, 5, 8] {
                    let row0 = (next() % 3) as usize;
                    let rows = row0 + in_dim;
                    let weights: std::vec::Vec<u8> = (0..rows * od * W::BYTES).map(|_| next() as u8).collect();
                    let l = Layer {
                        in_dim: rows as u16,
                        out_dim: od as u16,
                        act_max: 0.0,
                        weights: &weights,
                        bias: &[],
                        scales: &[],
                        requant: &[],
                    };
                    let mut input = [[0i16; MAX_WIDTH]; 8];
                    for row in input.iter_mut() {
                        for x in row.iter_mut() {
                            // half zeros (ReLU), the rest small enough for i32 sums
                            *x = if next() % 2 == 0 { 0 } else { (next() % 4096) as i16 - 2048 };
                        }
                    }
                    let mut acc = [[W::A::default(); MAX_WIDTH]; 8];
                    accumulate_int::<W, MAX_WIDTH>(&l, Input { rows: &input, row0, width: in_dim, n }, &mut acc);
                    for s in 0..8 {
                        for c in 0..od {
                            let mut want = 0i64;
                            if s < n {
                                for j in 0..in_dim {
                                    let k = ((row0 + j) * od + c) * W::BYTES;
                                    want += input[s][j] as i64 * W::mul(1, &weights[k..]).into();
                                }
                            }
                            assert_eq!(acc[s][c].into(), want, "in {in_dim} out {od} n {n} s {s} c {c}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn int8_kernel_matches_the_naive_sum() {
        check_against_naive::<W8>();
    }

    #[test]
    fn int16_kernel_matches_the_naive_sum() {
        check_against_naive::<W16>();
    }
}
