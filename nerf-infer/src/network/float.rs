//! The network in f32: activations accumulate in place, in the portable
//! register-tiled kernel ([`crate::layer::accumulate`], compiled for the
//! CPU's widest registers by [`crate::arch::accumulate_f32`]).

use super::contract::{Act, Inputs, LayerKernel, Numbers, ENC_MAX, F32};
use crate::arch::accumulate_f32;
use crate::encoding::encode_f32;
use crate::format::{read_f32, Layer, Model, Network};
use crate::layer::Input;
use crate::limits::FOOTPRINT_POINTS;
use crate::limits::MAX_WIDTH;
use crate::tensor::Zero;

/// The f32 path's per-ray start of the view layer's sums (it accumulates
/// in the activations themselves).
#[derive(Clone)]
pub struct ViewBias([f32; MAX_WIDTH]);

impl Default for ViewBias {
    fn default() -> Self {
        Self::ZERO
    }
}

impl Zero for ViewBias {
    const ZERO: Self = Self([0.0; MAX_WIDTH]);
}

impl Numbers for F32 {
    type X = f32;
    type Pos = [f32; 3];
    type Sigma = f32;
    type Rgb = [f32; 3];
    type Acc<const B: usize> = ViewBias;

    fn encode_rows(
        model: &Model<'_>,
        pos: &[[f32; 3]],
        foot: Option<&[[[f32; 3]; FOOTPRINT_POINTS]]>,
        enc: &mut [[f32; ENC_MAX]],
    ) -> usize {
        let e = &model.encoding;
        let mut pd = 0;
        for (s, p) in pos.iter().enumerate() {
            pd = encode_f32(*p, e.pos_freqs as usize, e.include_input, &mut enc[s]);
            // (models with a feature grid do not load without the feature)
            #[cfg(feature = "feature-grid")]
            if let Some(f) = &model.features {
                match foot {
                    Some(ft) => f.encode_f32_mean(&ft[s], &mut enc[s][pd..pd + f.dim()]),
                    None => f.encode_f32(*p, &mut enc[s][pd..]),
                }
                pd += f.dim();
            }
        }
        #[cfg(not(feature = "feature-grid"))]
        let _ = foot;
        pd
    }

    fn encode_dir(model: &Model<'_>, dir: [f32; 3], out: &mut [f32; ENC_MAX]) -> usize {
        let e = &model.encoding;
        encode_f32(dir, e.dir_freqs as usize, e.include_input, out)
    }
}

/// `out[s][..] = start(c)` for the first `n` samples.
fn init(start: impl Fn(usize) -> f32, out_dim: usize, n: usize, out: &mut [[f32; MAX_WIDTH]]) {
    for row in out[..n].iter_mut() {
        for (c, y) in row[..out_dim].iter_mut().enumerate() {
            *y = start(c);
        }
    }
}

fn relu(out_dim: usize, n: usize, buf: &mut [[f32; MAX_WIDTH]]) {
    for row in buf[..n].iter_mut() {
        for y in row[..out_dim].iter_mut() {
            *y = y.max(0.0);
        }
    }
}

/// `1 / (1 + e^−x)` in `[0, 1]`; NaN (from activations that overflowed to
/// ±∞ and met) maps to 0.5, the value at x = 0.
fn sigmoid(x: f32) -> f32 {
    if x.is_nan() {
        return 0.5;
    }
    1.0 / (1.0 + libm::expf(-x))
}

/// f32 weights.
impl LayerKernel<F32> for F32 {
    fn dense<const B: usize>(
        _net: &Network<'_>,
        l: &Layer<'_>,
        view: bool,
        inputs: Inputs<'_, f32, MAX_WIDTH>,
        n: usize,
        acc: &mut ViewBias,
        out: &mut [[f32; MAX_WIDTH]],
        act: Act,
    ) {
        let od = l.out_dim as usize;
        if view {
            init(|c| acc.0[c], od, n, out);
        } else {
            init(|c| read_f32(l.bias, c), od, n, out);
        }
        let mut row0 = 0;
        if let Some((enc, pd)) = inputs.enc {
            accumulate_f32::<ENC_MAX>(l, Input { rows: enc, row0, width: pd, n }, out);
            row0 = pd;
        }
        if let Some((prev, w)) = inputs.prev {
            accumulate_f32::<MAX_WIDTH>(l, Input { rows: prev, row0, width: w, n }, out);
        }
        if act == Act::Relu {
            relu(od, n, out);
        }
    }

    fn sigma_head<const B: usize>(
        l: &Layer<'_>,
        _head16: Option<&Layer<'_>>,
        trunk: &[[f32; MAX_WIDTH]],
        w: usize,
        n: usize,
        _acc: &mut ViewBias,
        sigma: &mut [f32; B],
    ) {
        for s in 0..n {
            let mut acc = read_f32(l.bias, 0);
            for j in 0..w {
                acc += trunk[s][j] * read_f32(l.weights, j);
            }
            sigma[s] = acc;
        }
    }

    fn rgb_head<const B: usize>(
        l: &Layer<'_>,
        _head16: Option<&Layer<'_>>,
        input: &[[f32; MAX_WIDTH]],
        dim: usize,
        n: usize,
        _acc: &mut ViewBias,
        rgb: &mut [[f32; 3]; B],
    ) {
        for s in 0..n {
            for c in 0..3 {
                let mut acc = read_f32(l.bias, c);
                for j in 0..dim {
                    acc += input[s][j] * read_f32(l.weights, j * 3 + c);
                }
                rgb[s][c] = sigmoid(acc);
            }
        }
    }

    /// `rows16` is empty: f32 models carry no 16-bit parts (validated).
    fn fold_view<const B: usize>(
        l: &Layer<'_>,
        _rows16: &[u8],
        dir: &[f32; ENC_MAX],
        nd: usize,
        w: usize,
        acc: &mut ViewBias,
    ) {
        let (od, view) = (l.out_dim as usize, &mut acc.0);
        for c in 0..od {
            view[c] = read_f32(l.bias, c);
        }
        for (j, &a) in dir[..nd].iter().enumerate() {
            for c in 0..od {
                view[c] += a * read_f32(l.weights, (w + j) * od + c);
            }
        }
    }
}
