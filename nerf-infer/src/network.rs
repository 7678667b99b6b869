//! The NeRF MLP evaluated on a block of up to `B` samples of one ray.
//!
//! Dense layers are computed in input-major "axpy" form: for each input `j`,
//! its weight row (all outputs) is loaded once and added, scaled by the
//! input, to each sample's accumulator. Zero inputs (ReLU) are skipped,
//! which changes no result. The direction part of the view layer is the
//! same for every sample of a ray, so it is folded into a per-ray bias by
//! `prepare_ray`.
//!
//! Fixed-point path: i16 activations; [`Scheme::I16`] weights accumulate in
//! i64, [`Scheme::I8`] weights in i32 (overflow excluded at load, see
//! [`check_i8_headroom`]); one [`crate::fixed::Requant`] per output channel.

use crate::encoding::{encode_f32, encode_fixed};
use crate::error::{Error, Result};
use crate::features::MAX_FEATURES;
use crate::fixed::{sat_i32, sigmoid_q12_q15};
use crate::format::{read_f32, read_i32, sigma_layer, Layer, Model, Network, Scheme, MAX_FREQS, MAX_WIDTH};

/// Longest encoded position or direction: `3 + 6·16` plus the feature
/// grid's values.
pub const ENC_MAX: usize = 3 + 6 * MAX_FREQS + MAX_FEATURES;

/// Per-block buffers of the f32 path (`B` samples; ≈ `B`·2.4 KiB + 1 KiB).
#[derive(Clone)]
pub struct BlockF32<const B: usize> {
    enc: [[f32; ENC_MAX]; B],
    h: [[f32; MAX_WIDTH]; B],
    g: [[f32; MAX_WIDTH]; B],
    view_bias: [f32; MAX_WIDTH],
    /// Raw density head output per sample.
    pub sigma: [f32; B],
    /// Colour per sample in `[0, 1]` (valid when requested).
    pub rgb: [[f32; 3]; B],
}

impl<const B: usize> Default for BlockF32<B> {
    fn default() -> Self {
        Self {
            enc: [[0.0; ENC_MAX]; B],
            h: [[0.0; MAX_WIDTH]; B],
            g: [[0.0; MAX_WIDTH]; B],
            view_bias: [0.0; MAX_WIDTH],
            sigma: [0.0; B],
            rgb: [[0.0; 3]; B],
        }
    }
}

/// `out[s][..] = bias` for the first `n` samples.
fn init_f32(bias: impl Fn(usize) -> f32, out_dim: usize, n: usize, out: &mut [[f32; MAX_WIDTH]]) {
    for row in out[..n].iter_mut() {
        for (c, y) in row[..out_dim].iter_mut().enumerate() {
            *y = bias(c);
        }
    }
}

/// Element arithmetic of a dense layer: input activations `X`, decoded
/// weights `Wd`, accumulators `A` (f32; or exact integers).
pub trait Mac {
    /// Input activation type.
    type X: Copy + Default + PartialEq;
    /// Weight decoded from its bytes.
    type Wd: Copy + Default;
    /// Accumulator type.
    type A: Copy + Default;
    /// Bytes per stored weight.
    const BYTES: usize;
    /// Decodes one little-endian weight.
    fn decode(b: &[u8]) -> Self::Wd;
    /// `acc += x · w`.
    fn mac(acc: &mut Self::A, x: Self::X, w: Self::Wd);
}

/// f32 activations and weights.
pub struct MacF32;

impl Mac for MacF32 {
    type X = f32;
    type Wd = f32;
    type A = f32;
    const BYTES: usize = 4;
    #[inline(always)]
    fn decode(b: &[u8]) -> f32 {
        f32::from_le_bytes([b[0], b[1], b[2], b[3]])
    }
    #[inline(always)]
    fn mac(acc: &mut f32, x: f32, w: f32) {
        *acc += x * w;
    }
}

/// Samples per register tile.
const TILE_S: usize = 4;
/// Outputs per register tile.
const TILE_C: usize = 32;

/// Outputs per register tile of both kernels: a layer whose width is a
/// multiple of this runs only whole tiles (the remainder takes a slower
/// loop), so pruning at export keeps widths on this grain by default.
pub const OUTPUT_TILE: usize = TILE_C;

/// `out[s][c] += Σ_j input[s][j] · W[row0 + j][c]` for the first `n`
/// samples and the outputs `c ≥ c_start`, `W` being `weights` with `od`
/// outputs per row.
///
/// Register-tiled: a tile of 4 samples × 32 outputs stays in registers
/// while the inputs stream past, each weight row segment loaded once for 4
/// samples. Inputs that are zero for the whole tile (ReLU) are skipped. Per
/// output the sum runs over `j` in ascending order, so results do not depend
/// on the tiling.
#[inline]
#[allow(clippy::too_many_arguments)]
fn accumulate<M: Mac, const N: usize>(
    weights: &[u8],
    od: usize,
    c_start: usize,
    row0: usize,
    input: &[[M::X; N]],
    in_dim: usize,
    n: usize,
    out: &mut [[M::A; MAX_WIDTH]],
) {
    let zero = M::X::default();
    let mut s0 = 0;
    while s0 < n {
        let sn = (n - s0).min(TILE_S);
        let rows = &input[s0..s0 + sn];
        let mut c0 = c_start;
        while c0 + TILE_C <= od {
            let mut acc = [[M::A::default(); TILE_C]; TILE_S];
            for s in 0..sn {
                acc[s].copy_from_slice(&out[s0 + s][c0..c0 + TILE_C]);
            }
            let [a0, a1, a2, a3] = &mut acc;
            for j in 0..in_dim {
                let x0 = rows[0][j];
                let x1 = if sn > 1 { rows[1][j] } else { zero };
                let x2 = if sn > 2 { rows[2][j] } else { zero };
                let x3 = if sn > 3 { rows[3][j] } else { zero };
                if x0 == zero && x1 == zero && x2 == zero && x3 == zero {
                    continue;
                }
                let base = ((row0 + j) * od + c0) * M::BYTES;
                let wrow = &weights[base..base + TILE_C * M::BYTES];
                for k in 0..TILE_C {
                    let w = M::decode(&wrow[k * M::BYTES..(k + 1) * M::BYTES]);
                    M::mac(&mut a0[k], x0, w);
                    M::mac(&mut a1[k], x1, w);
                    M::mac(&mut a2[k], x2, w);
                    M::mac(&mut a3[k], x3, w);
                }
            }
            for s in 0..sn {
                out[s0 + s][c0..c0 + TILE_C].copy_from_slice(&acc[s]);
            }
            c0 += TILE_C;
        }
        if c0 < od {
            for s in 0..sn {
                for j in 0..in_dim {
                    let x = rows[s][j];
                    if x == zero {
                        continue;
                    }
                    let base = ((row0 + j) * od) * M::BYTES;
                    for c in c0..od {
                        let w = M::decode(&weights[base + c * M::BYTES..base + (c + 1) * M::BYTES]);
                        M::mac(&mut out[s0 + s][c], x, w);
                    }
                }
            }
        }
        s0 += TILE_S;
    }
}

#[inline]
fn accumulate_f32<const N: usize>(
    l: &Layer<'_>,
    row0: usize,
    input: &[[f32; N]],
    in_dim: usize,
    n: usize,
    out: &mut [[f32; MAX_WIDTH]],
) {
    accumulate::<MacF32, N>(l.weights, l.out_dim as usize, 0, row0, input, in_dim, n, out);
}

fn relu_f32(out_dim: usize, n: usize, buf: &mut [[f32; MAX_WIDTH]]) {
    for row in buf[..n].iter_mut() {
        for y in row[..out_dim].iter_mut() {
            *y = y.max(0.0);
        }
    }
}

/// `1 / (1 + e^−x)` in `[0, 1]`; NaN (from activations that overflowed to
/// ±∞ and met) maps to 0.5, the value at x = 0.
fn sigmoid_f32(x: f32) -> f32 {
    if x.is_nan() {
        return 0.5;
    }
    1.0 / (1.0 + libm::expf(-x))
}

impl<const B: usize> BlockF32<B> {
    /// Per-ray setup of network `net`: folds `γ(viewdir)` into the view
    /// layer's bias. No-op without the view branch.
    pub fn prepare_ray(&mut self, model: &Model<'_>, net: &Network<'_>, viewdir: [f32; 3]) {
        let t = &model.topology;
        if !t.view_dependent {
            return;
        }
        let e = &model.encoding;
        let l = &net.layers[sigma_layer(t) + 2];
        let mut enc = [0.0f32; ENC_MAX];
        let nd = encode_f32(viewdir, e.dir_freqs as usize, e.include_input, &mut enc);
        let od = l.out_dim as usize;
        let w = l.in_dim as usize - nd; // the feature layer's width
        for c in 0..od {
            self.view_bias[c] = read_f32(l.bias, c);
        }
        for (j, &a) in enc[..nd].iter().enumerate() {
            for c in 0..od {
                self.view_bias[c] += a * read_f32(l.weights, (w + j) * od + c);
            }
        }
    }

    /// The trunk and density head at the normalised positions `pos`
    /// (≤ `B`): fills `sigma` and keeps the trunk's output for
    /// [`BlockF32::eval_colour`].
    pub fn eval_density(&mut self, model: &Model<'_>, net: &Network<'_>, pos: &[[f32; 3]]) {
        let n = pos.len();
        let t = &model.topology;
        let e = &model.encoding;
        let mut pd = 0;
        for (s, p) in pos.iter().enumerate() {
            pd = encode_f32(*p, e.pos_freqs as usize, e.include_input, &mut self.enc[s]);
            // (models with a feature grid do not load without the feature)
            #[cfg(feature = "feature-grid")]
            if let Some(f) = &model.features {
                f.encode_f32(*p, &mut self.enc[s][pd..]);
                pd += f.dim();
            }
        }
        let layers = &net.layers;
        // layer widths come from the layers: pruned ones are narrower
        let width = |k: usize| layers[k].out_dim as usize;
        // Trunk: h ← layer 0, then alternate between h and g.
        let l0 = &layers[0];
        init_f32(|c| read_f32(l0.bias, c), width(0), n, &mut self.h);
        accumulate_f32(l0, 0, &self.enc, pd, n, &mut self.h);
        relu_f32(width(0), n, &mut self.h);
        let mut in_h = true;
        for (i, l) in layers.iter().enumerate().take(t.depth as usize).skip(1) {
            let (src, dst) = if in_h { (&self.h, &mut self.g) } else { (&self.g, &mut self.h) };
            init_f32(|c| read_f32(l.bias, c), width(i), n, dst);
            let mut row0 = 0;
            if t.is_skip(i) {
                accumulate_f32(l, 0, &self.enc, pd, n, dst);
                row0 = pd;
            }
            accumulate_f32(l, row0, src, width(i - 1), n, dst);
            relu_f32(width(i), n, dst);
            in_h = !in_h;
        }
        debug_assert_eq!(in_h, trunk_in_h(t.depth));
        let trunk = if in_h { &self.h } else { &self.g };
        let ls = &layers[sigma_layer(t)];
        let w = width(sigma_layer(t) - 1);
        for s in 0..n {
            let mut acc = read_f32(ls.bias, 0);
            for j in 0..w {
                acc += trunk[s][j] * read_f32(ls.weights, j);
            }
            self.sigma[s] = acc;
        }
    }

    /// The colour branch for samples `rows` (ascending, each < the count
    /// given to the last [`BlockF32::eval_density`]): `rgb[j]` is the
    /// colour of sample `rows[j]`. Samples whose weight is zero need none.
    pub fn eval_colour(&mut self, model: &Model<'_>, net: &Network<'_>, rows: &[usize]) {
        let n = rows.len();
        let t = &model.topology;
        let Self { h, g, view_bias, rgb, .. } = self;
        let (trunk, spare) = if trunk_in_h(t.depth) { (h, g) } else { (g, h) };
        let layers = &net.layers;
        let si = sigma_layer(t);
        let w = layers[si - 1].out_dim as usize;
        gather_rows(trunk, rows, w);
        let (rgb_in, rgb_dim, lr) = if t.view_dependent {
            let lf = &layers[si + 1];
            let fw = lf.out_dim as usize;
            init_f32(|c| read_f32(lf.bias, c), fw, n, spare);
            accumulate_f32(lf, 0, trunk, w, n, spare);
            let lv = &layers[si + 2];
            let vw = lv.out_dim as usize;
            init_f32(|c| view_bias[c], vw, n, trunk);
            accumulate_f32(lv, 0, spare, fw, n, trunk);
            relu_f32(vw, n, trunk);
            (&*trunk, vw, &layers[si + 3])
        } else {
            (&*trunk, w, &layers[si + 1])
        };
        for s in 0..n {
            for c in 0..3 {
                let mut acc = read_f32(lr.bias, c);
                for j in 0..rgb_dim {
                    acc += rgb_in[s][j] * read_f32(lr.weights, j * 3 + c);
                }
                rgb[s][c] = sigmoid_f32(acc);
            }
        }
    }
}

/// Moves the first `width` values of rows `rows` (ascending, `rows[j] ≥ j`)
/// to the front of `buf`, row `rows[j]` to row `j` (a forward copy).
fn gather_rows<X: Copy>(buf: &mut [[X; MAX_WIDTH]], rows: &[usize], width: usize) {
    for (j, &k) in rows.iter().enumerate() {
        if k != j {
            let (to, from) = buf.split_at_mut(k);
            to[j][..width].copy_from_slice(&from[0][..width]);
        }
    }
}

/// Integer weight element types of the fixed-point path.
pub trait IntWeight {
    /// Accumulator: i64 for int16 weights, i32 for int8 weights.
    type Acc: Copy + Default + core::ops::AddAssign + Into<i64>;
    /// Bytes per weight.
    const BYTES: usize;
    /// Whether [`IntWeight::accumulate_wide`] also takes layers narrower
    /// than the portable tile (the colour head) faster than the scalar loop.
    const WIDE_TAKES_NARROW: bool = false;
    /// `a · w` in the accumulator type (`w` is the weight's bytes).
    fn mul(a: i16, w: &[u8]) -> Self::Acc;
    /// The weight stored in `b`, sign-extended.
    fn decode(b: &[u8]) -> i32;
    /// An exact i32 product in the accumulator type.
    fn widen(p: i32) -> Self::Acc;
    /// A bias or partial sum (checked at load to fit the accumulator).
    fn from_i64(b: i64) -> Self::Acc;
    /// `acc[s][c] += Σ_j input[s][j] · W[row0 + j][c]` for a layer at
    /// least the portable tile wide (or any width if
    /// [`IntWeight::WIDE_TAKES_NARROW`]): the portable register-tiled kernel;
    /// int8 weights use AVX-512 VNNI or AVX2 where the build enables it.
    #[inline]
    fn accumulate_wide<const N: usize>(
        l: &Layer<'_>,
        row0: usize,
        input: &[[i16; N]],
        in_dim: usize,
        n: usize,
        acc: &mut [[Self::Acc; MAX_WIDTH]],
    ) where
        Self: Sized,
    {
        accumulate::<MacInt<Self>, N>(l.weights, l.out_dim as usize, 0, row0, input, in_dim, n, acc);
    }
    /// `out[s][c] = clamp(requantised acc[s][c], lo, hi)` for the first
    /// `n` samples and every output of `l` (the portable loop; int8 weights
    /// use AVX2 where the build enables it without AVX-512 VNNI).
    #[inline]
    fn requant_rows(
        l: &Layer<'_>,
        n: usize,
        acc: &[[Self::Acc; MAX_WIDTH]],
        out: &mut [[i16; MAX_WIDTH]],
        (lo, hi): (i16, i16),
    ) {
        for (a, o) in acc[..n].iter().zip(out[..n].iter_mut()) {
            for c in 0..l.out_dim as usize {
                o[c] = l.requant(c).apply(a[c].into()).clamp(lo as i64, hi as i64) as i16;
            }
        }
    }
    /// Picks this type's accumulator buffer.
    fn pick<'a, const B: usize>(
        a64: &'a mut [[i64; MAX_WIDTH]; B],
        a32: &'a mut [[i32; MAX_WIDTH]; B],
    ) -> &'a mut [[Self::Acc; MAX_WIDTH]; B];
}

/// int16 weights, i64 accumulation.
pub struct W16;
/// int8 weights, i32 accumulation.
pub struct W8;

impl IntWeight for W16 {
    type Acc = i64;
    const BYTES: usize = 2;
    #[inline(always)]
    fn mul(a: i16, w: &[u8]) -> i64 {
        a as i64 * i16::from_le_bytes([w[0], w[1]]) as i64
    }
    fn from_i64(b: i64) -> i64 {
        b
    }
    #[inline(always)]
    fn decode(b: &[u8]) -> i32 {
        i16::from_le_bytes([b[0], b[1]]) as i32
    }
    #[inline(always)]
    fn widen(p: i32) -> i64 {
        p as i64
    }
    fn pick<'a, const B: usize>(
        a64: &'a mut [[i64; MAX_WIDTH]; B],
        _: &'a mut [[i32; MAX_WIDTH]; B],
    ) -> &'a mut [[i64; MAX_WIDTH]; B] {
        a64
    }
}

impl IntWeight for W8 {
    type Acc = i32;
    const BYTES: usize = 1;
    /// The AVX2 kernel pads a short output group.
    const WIDE_TAKES_NARROW: bool = cfg!(all(
        target_arch = "x86_64",
        target_feature = "avx2",
        not(all(target_feature = "avx512bw", target_feature = "avx512vnni"))
    ));
    #[inline(always)]
    fn mul(a: i16, w: &[u8]) -> i32 {
        a as i32 * w[0] as i8 as i32
    }
    fn from_i64(b: i64) -> i32 {
        b as i32
    }
    /// VNNI for whole 32-wide tiles, the portable loop for the rest.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512bw", target_feature = "avx512vnni"))]
    #[inline]
    fn accumulate_wide<const N: usize>(
        l: &Layer<'_>,
        row0: usize,
        input: &[[i16; N]],
        in_dim: usize,
        n: usize,
        acc: &mut [[i32; MAX_WIDTH]],
    ) {
        let od = l.out_dim as usize;
        crate::vnni::accumulate_i8(l.weights, od, row0, input, in_dim, n, acc);
        accumulate::<MacInt<W8>, N>(l.weights, od, od - od % TILE_C, row0, input, in_dim, n, acc);
    }
    /// AVX2 `vpmaddwd`, 8 outputs at a time (a short last group padded).
    #[cfg(all(
        target_arch = "x86_64",
        target_feature = "avx2",
        not(all(target_feature = "avx512bw", target_feature = "avx512vnni"))
    ))]
    #[inline]
    fn accumulate_wide<const N: usize>(
        l: &Layer<'_>,
        row0: usize,
        input: &[[i16; N]],
        in_dim: usize,
        n: usize,
        acc: &mut [[i32; MAX_WIDTH]],
    ) {
        crate::avx2::accumulate_i8(l.weights, l.out_dim as usize, row0, input, in_dim, n, acc);
    }
    #[cfg(all(
        target_arch = "x86_64",
        target_feature = "avx2",
        not(all(target_feature = "avx512bw", target_feature = "avx512vnni"))
    ))]
    #[inline]
    fn requant_rows(
        l: &Layer<'_>,
        n: usize,
        acc: &[[i32; MAX_WIDTH]],
        out: &mut [[i16; MAX_WIDTH]],
        bounds: (i16, i16),
    ) {
        crate::avx2::requant_i32(l, n, acc, out, bounds);
    }
    #[inline(always)]
    fn decode(b: &[u8]) -> i32 {
        b[0] as i8 as i32
    }
    #[inline(always)]
    fn widen(p: i32) -> i32 {
        p
    }
    fn pick<'a, const B: usize>(
        _: &'a mut [[i64; MAX_WIDTH]; B],
        a32: &'a mut [[i32; MAX_WIDTH]; B],
    ) -> &'a mut [[i32; MAX_WIDTH]; B] {
        a32
    }
}

/// Checks that no int8 layer can overflow its i32 accumulator:
/// `Σⱼ |W[j][c]| · 32768 + |bias[c]| ≤ i32::MAX` for every output `c`.
pub fn check_i8_headroom(net: &Network<'_>) -> Result<()> {
    if net.scheme != Scheme::I8 {
        return Ok(());
    }
    for (i, l) in net.layers.iter().enumerate() {
        let od = l.out_dim as usize;
        for c in 0..od {
            let mut sum = (read_i32(l.bias, c) as i64).abs();
            for j in 0..l.in_dim as usize {
                sum += ((l.weights[j * od + c] as i8 as i64).abs()) << 15;
            }
            if sum > i32::MAX as i64 {
                return Err(Error::InvalidScale(i as u8));
            }
        }
    }
    Ok(())
}

/// Per-block buffers of the fixed-point path (`B` samples; ≈ `B`·4.7 KiB + 2 KiB).
#[derive(Clone)]
pub struct BlockFixed<const B: usize> {
    enc: [[i16; ENC_MAX]; B],
    h: [[i16; MAX_WIDTH]; B],
    g: [[i16; MAX_WIDTH]; B],
    acc64: [[i64; MAX_WIDTH]; B],
    acc32: [[i32; MAX_WIDTH]; B],
    view_acc: [i64; MAX_WIDTH],
    /// Density per sample, Q10 (before ReLU).
    pub sigma: [i32; B],
    /// Colour per sample, Q15 (valid when requested).
    pub rgb: [[u16; 3]; B],
}

impl<const B: usize> Default for BlockFixed<B> {
    fn default() -> Self {
        Self {
            enc: [[0; ENC_MAX]; B],
            h: [[0; MAX_WIDTH]; B],
            g: [[0; MAX_WIDTH]; B],
            acc64: [[0; MAX_WIDTH]; B],
            acc32: [[0; MAX_WIDTH]; B],
            view_acc: [0; MAX_WIDTH],
            sigma: [0; B],
            rgb: [[0; 3]; B],
        }
    }
}

/// The [`Mac`] of an integer weight type: i16 inputs, i32 products.
pub struct MacInt<W>(core::marker::PhantomData<W>);

impl<W: IntWeight> Mac for MacInt<W> {
    type X = i16;
    type Wd = i32;
    type A = W::Acc;
    const BYTES: usize = W::BYTES;
    #[inline(always)]
    fn decode(b: &[u8]) -> i32 {
        W::decode(b)
    }
    #[inline(always)]
    fn mac(acc: &mut W::Acc, x: i16, w: i32) {
        *acc += W::widen(x as i32 * w);
    }
}

/// `acc[s][c] += Σ_j input[s][j] · W[row0 + j][c]` (integer weights, exact).
#[inline]
fn accumulate_int<W: IntWeight, const N: usize>(
    l: &Layer<'_>,
    row0: usize,
    input: &[[i16; N]],
    in_dim: usize,
    n: usize,
    acc: &mut [[W::Acc; MAX_WIDTH]],
) {
    let od = l.out_dim as usize;
    // x86 only: on a Cortex-M the unrolled loop costs 6 KiB of flash for 1 %
    // fewer instructions
    if od == 1 && cfg!(target_arch = "x86_64") {
        // the density head: contiguous weights, a dot product that vectorises
        let w = &l.weights[row0 * W::BYTES..(row0 + in_dim) * W::BYTES];
        for (x, a) in input[..n].iter().zip(acc.iter_mut()) {
            let mut sum = W::Acc::default();
            for (&x, w) in x[..in_dim].iter().zip(w.chunks_exact(W::BYTES)) {
                sum += W::mul(x, w);
            }
            a[0] += sum;
        }
        return;
    }
    if od < TILE_C && !W::WIDE_TAKES_NARROW {
        // the colour head: one dot product per output
        for (x, a) in input[..n].iter().zip(acc.iter_mut()) {
            for c in 0..od {
                let mut sum = W::Acc::default();
                for j in 0..in_dim {
                    let k = ((row0 + j) * od + c) * W::BYTES;
                    sum += W::mul(x[j], &l.weights[k..k + W::BYTES]);
                }
                a[c] += sum;
            }
        }
        return;
    }
    W::accumulate_wide(l, row0, input, in_dim, n, acc);
}

/// `acc[s][c] = bias[c]`, or the per-ray view accumulator when given.
fn init_int<W: IntWeight>(l: &Layer<'_>, view: Option<&[i64; MAX_WIDTH]>, n: usize, acc: &mut [[W::Acc; MAX_WIDTH]]) {
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

impl<const B: usize> BlockFixed<B> {
    /// Per-ray setup: folds the encoded direction (Q24 unit vector) into the
    /// view layer's accumulator bias. No-op without the view branch.
    pub fn prepare_ray<W: IntWeight>(&mut self, model: &Model<'_>, net: &Network<'_>, viewdir_q24: [i32; 3]) {
        let t = &model.topology;
        if !t.view_dependent {
            return;
        }
        let e = &model.encoding;
        let l = &net.layers[sigma_layer(t) + 2];
        let mut enc = [0i16; ENC_MAX];
        let nd = encode_fixed(viewdir_q24, e.dir_freqs as usize, e.include_input, e.raw_frac_bits as u32, &mut enc);
        let od = l.out_dim as usize;
        let w = l.in_dim as usize - nd; // the feature layer's width
        if cfg!(target_arch = "x86_64") {
            // the layer kernel on one sample, rows w.. (the SIMD one where
            // built; kept off the Cortex-M for flash)
            let acc = W::pick(&mut self.acc64, &mut self.acc32);
            init_int::<W>(l, None, 1, acc);
            accumulate_int::<W, ENC_MAX>(l, w, core::slice::from_ref(&enc), nd, 1, acc);
            for (v, &a) in self.view_acc[..od].iter_mut().zip(&acc[0][..od]) {
                *v = a.into();
            }
            return;
        }
        for c in 0..od {
            let mut acc: W::Acc = W::from_i64(read_i32(l.bias, c) as i64);
            for (j, &a) in enc[..nd].iter().enumerate() {
                let k = ((w + j) * od + c) * W::BYTES;
                acc += W::mul(a, &l.weights[k..k + W::BYTES]);
            }
            self.view_acc[c] = acc.into();
        }
    }

    /// The trunk and density head at Q24 normalised positions `pos` (≤ `B`):
    /// fills `sigma` (Q10) and keeps the trunk's output for
    /// [`BlockFixed::eval_colour`].
    pub fn eval_density<W: IntWeight>(&mut self, model: &Model<'_>, net: &Network<'_>, pos: &[[i32; 3]]) {
        let n = pos.len();
        let t = &model.topology;
        let e = &model.encoding;
        let Self { enc, h, g, acc64, acc32, sigma, .. } = self;
        let acc = W::pick(acc64, acc32);
        let mut pd = 0;
        for (s, p) in pos.iter().enumerate() {
            pd = encode_fixed(*p, e.pos_freqs as usize, e.include_input, e.raw_frac_bits as u32, &mut enc[s]);
        }
        #[cfg(feature = "feature-grid")]
        if let Some(f) = &model.features {
            f.encode_fixed_rows(pos, enc, pd);
            pd += f.dim();
        }
        let layers = &net.layers;
        // layer widths come from the layers: pruned ones are narrower
        let width = |k: usize| layers[k].out_dim as usize;
        let relu = relu_bounds(net);
        let l0 = &layers[0];
        init_int::<W>(l0, None, n, acc);
        accumulate_int::<W, ENC_MAX>(l0, 0, enc, pd, n, acc);
        W::requant_rows(l0, n, acc, h, relu);
        let mut in_h = true;
        for (i, l) in layers.iter().enumerate().take(t.depth as usize).skip(1) {
            let (src, dst) = if in_h { (&*h, &mut *g) } else { (&*g, &mut *h) };
            init_int::<W>(l, None, n, acc);
            let mut row0 = 0;
            if t.is_skip(i) {
                accumulate_int::<W, ENC_MAX>(l, 0, enc, pd, n, acc);
                row0 = pd;
            }
            accumulate_int::<W, MAX_WIDTH>(l, row0, src, width(i - 1), n, acc);
            W::requant_rows(l, n, acc, dst, relu);
            in_h = !in_h;
        }
        debug_assert_eq!(in_h, trunk_in_h(t.depth));
        let trunk = if in_h { &*h } else { &*g };
        let si = sigma_layer(t);
        let ls = &layers[si];
        init_int::<W>(ls, None, n, acc);
        accumulate_int::<W, MAX_WIDTH>(ls, 0, trunk, width(si - 1), n, acc);
        let rs = ls.requant(0);
        for s in 0..n {
            sigma[s] = sat_i32(rs.apply(acc[s][0].into()));
        }
    }

    /// The colour branch for samples `rows` (ascending, each < the count
    /// given to the last [`BlockFixed::eval_density`]): `rgb[j]` (Q15) is the
    /// colour of sample `rows[j]`. Samples whose weight is zero need none.
    pub fn eval_colour<W: IntWeight>(&mut self, model: &Model<'_>, net: &Network<'_>, rows: &[usize]) {
        let n = rows.len();
        let t = &model.topology;
        let Self { h, g, acc64, acc32, view_acc, rgb, .. } = self;
        let acc = W::pick(acc64, acc32);
        let (trunk, spare) = if trunk_in_h(t.depth) { (h, g) } else { (g, h) };
        let layers = &net.layers;
        let width = |k: usize| layers[k].out_dim as usize;
        gather_rows(trunk, rows, width(sigma_layer(t) - 1));
        let relu = relu_bounds(net);
        let linear = linear_bounds(net);
        let si = sigma_layer(t);
        let w = width(si - 1);
        let (rgb_in, rgb_dim, lr) = if t.view_dependent {
            let lf = &layers[si + 1];
            init_int::<W>(lf, None, n, acc);
            accumulate_int::<W, MAX_WIDTH>(lf, 0, trunk, w, n, acc);
            W::requant_rows(lf, n, acc, spare, linear);
            let lv = &layers[si + 2];
            init_int::<W>(lv, Some(view_acc), n, acc);
            accumulate_int::<W, MAX_WIDTH>(lv, 0, spare, width(si + 1), n, acc);
            W::requant_rows(lv, n, acc, trunk, relu);
            (&*trunk, width(si + 2), &layers[si + 3])
        } else {
            (&*trunk, w, &layers[si + 1])
        };
        init_int::<W>(lr, None, n, acc);
        accumulate_int::<W, MAX_WIDTH>(lr, 0, rgb_in, rgb_dim, n, acc);
        for c in 0..3 {
            let r = lr.requant(c);
            for s in 0..n {
                rgb[s][c] = sigmoid_q12_q15(sat_i32(r.apply(acc[s][c].into())));
            }
        }
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

/// Whether the trunk of a `depth`-layer network ends in `h` (layers
/// alternate `h`, `g`, `h`, … starting with `h`).
fn trunk_in_h(depth: u8) -> bool {
    depth % 2 == 1
}

/// The ReLU of hidden activations: i16, or u8 when the network says so.
fn relu_bounds(net: &Network<'_>) -> (i16, i16) {
    (0, if net.act_bits == 8 { 255 } else { i16::MAX })
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::fixed::Requant;

    /// The dispatching integer kernel (VNNI or AVX2 where built, heads as dot
    /// products) against the plain triple loop, over the shapes the format
    /// allows: odd and even inputs, narrow and wide outputs, short tiles.
    fn check_against_naive<W: IntWeight>() {
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
                    let mut acc = [[W::Acc::default(); MAX_WIDTH]; 8];
                    accumulate_int::<W, MAX_WIDTH>(&l, row0, &input, in_dim, n, &mut acc);
                    for s in 0..8 {
                        for c in 0..od {
                            let mut want = 0i64;
                            if s < n {
                                for j in 0..in_dim {
                                    let k = ((row0 + j) * od + c) * W::BYTES;
                                    want += input[s][j] as i64 * W::decode(&weights[k..]) as i64;
                                }
                            }
                            assert_eq!(acc[s][c].into(), want, "in {in_dim} out {od} n {n} s {s} c {c}");
                        }
                    }
                }
            }
        }
    }

    /// The requantiser in use for int8 accumulators (AVX2 where built)
    /// against `Requant::apply` and a clamp, over every shift, multipliers
    /// at the ends of their range, accumulators at the ends of i32, and the
    /// ReLU and linear bounds of both activation widths.
    #[test]
    fn int8_requantisation_matches_requant_apply() {
        let mut h = 0x2545_f491u32;
        let mut next = move || {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            h
        };
        let od = 67; // 16 groups of 4 and a remainder
        let mut acc = [[0i32; MAX_WIDTH]; 8];
        let edges = [i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX];
        for (s, row) in acc.iter_mut().enumerate() {
            for (c, a) in row[..od].iter_mut().enumerate() {
                *a = if (s + c) % 5 == 0 { edges[(s * 7 + c) % edges.len()] } else { next() as i32 >> (next() % 31) };
            }
        }
        for shift in Requant::MIN_SHIFT..=Requant::MAX_SHIFT {
            let mut requant = std::vec::Vec::new();
            let factors: std::vec::Vec<Requant> = (0..od)
                .map(|c| {
                    let multiplier = match c % 4 {
                        0 => 1 << 30,
                        1 => i32::MAX,
                        2 if shift == 0 => 0,
                        _ => (1 << 30) + (next() as i32 & 0x3fff_ffff),
                    };
                    Requant { multiplier, shift }
                })
                .collect();
            for r in &factors {
                requant.extend_from_slice(&r.multiplier.to_le_bytes());
                requant.extend_from_slice(&r.shift.to_le_bytes());
            }
            let l = Layer {
                in_dim: 1,
                out_dim: od as u16,
                act_max: 0.0,
                weights: &[],
                bias: &[],
                scales: &[],
                requant: &requant,
            };
            for bounds in [(0, i16::MAX), (0, 255), (i16::MIN, i16::MAX), (-127, 127)] {
                for n in [1, 5, 8] {
                    let mut out = [[0x5555i16; MAX_WIDTH]; 8];
                    W8::requant_rows(&l, n, &acc, &mut out, bounds);
                    for s in 0..8 {
                        for c in 0..od {
                            let want = if s < n {
                                factors[c].apply(acc[s][c] as i64).clamp(bounds.0 as i64, bounds.1 as i64) as i16
                            } else {
                                0x5555
                            };
                            assert_eq!(out[s][c], want, "shift {shift} bounds {bounds:?} n {n} s {s} c {c}");
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
