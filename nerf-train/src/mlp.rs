//! The NeRF MLP in f32 with a hand-written backward pass.
//!
//! Parameters are one flat `Vec<f32>` per network, layer after layer, each
//! layer as its weights `[in][out]` (input-major, the model format's layout)
//! followed by its bias `[out]`. Layer order and shapes come from
//! [`nerf_infer::format::expected_shape`], so the trainer and the kernel
//! cannot disagree on them.
//!
//! With a learned feature grid ([`Mlp::with_features`]) its table follows
//! the layers in the parameter vector (level, entry, value: the model
//! format's order) and its values follow γ(x) in the trunk's input.
//!
//! Forward and backward work on a chunk of `S` samples belonging to `R`
//! rays with `S/R` consecutive samples per ray (the view direction is per
//! ray). Matrix products go through [`crate::gemm::matmul`].

use crate::gemm::{matmul, View};
use nerf_infer::camera::FOOTPRINT_POINTS;
use nerf_infer::encoding::encode_f32;
use nerf_infer::features::{Corners, FeatureGrid};
use nerf_infer::format::{expected_shape, Encoding, Topology};
use nerf_infer::per_width;
use rayon::prelude::*;

/// Where one layer's tensors sit in the flat parameter vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LayerSlot {
    /// Input width.
    pub din: usize,
    /// Output width.
    pub dout: usize,
    /// Offset of the weights (`din·dout` values, `[in][out]`).
    pub w: usize,
    /// Offset of the bias (`dout` values).
    pub b: usize,
}

/// Shape of one network and its parameter layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Mlp {
    /// Network shape.
    pub topo: Topology,
    /// Positional encoding.
    pub enc: Encoding,
    /// Layer tensors in the flat parameter vector.
    pub slots: Vec<LayerSlot>,
    /// The feature grid's shape (its `table` empty: the values are
    /// parameters from [`Mlp::table`] on).
    pub features: Option<FeatureGrid<'static>>,
    /// Offset of the feature grid's table (= the layers' parameter count).
    pub table: usize,
    /// Total parameter count.
    pub n_params: usize,
}

/// The feature-grid part of one chunk's backward pass, for
/// [`Mlp::scatter_table`]: the corners of each sample and level and the
/// gradient of the grid values.
#[derive(Clone, Debug, Default)]
pub struct GridGrad {
    corners: Vec<Corners>,
    dgf: Vec<f32>,
    s: usize,
}

/// Forward activations of a chunk, kept for the backward pass.
#[derive(Clone, Debug, Default)]
pub struct Acts {
    s: usize,
    /// Feature-grid points per sample: 1, or [`FOOTPRINT_POINTS`] with a pixel footprint
    /// ([`Mlp::encode_footprint`]); `corners` and the backward's `dgf` hold `S·k` points.
    k: usize,
    r: usize,
    enc: Vec<f32>,
    /// Feature-grid values per sample (`S × grid_dim`, the footprint's
    /// mean with one) and the corners of their `S·k` points, level after
    /// level (`levels × S·k`: the scatter reads one level at a time).
    gf: Vec<f32>,
    corners: Vec<Corners>,
    dgf: Vec<f32>,
    dgf_part: Vec<f32>,
    denc: Vec<f32>,
    h: Vec<Vec<f32>>,
    /// Raw density per sample (before ReLU).
    pub sigma: Vec<f32>,
    feat: Vec<f32>,
    dirpart: Vec<f32>,
    view: Vec<f32>,
    /// Colour per sample in `[0, 1]`, 3 per sample.
    pub rgb: Vec<f32>,
    // backward scratch
    dh: Vec<f32>,
    dtmp: Vec<f32>,
    dview: Vec<f32>,
    dray: Vec<f32>,
}

fn resize(v: &mut Vec<f32>, n: usize) {
    v.resize(n, 0.0);
}

impl Mlp {
    /// The layout for a topology and encoding.
    pub fn new(topo: Topology, enc: Encoding) -> Self {
        let mut slots = Vec::new();
        let mut off = 0;
        for i in 0..topo.layer_count() {
            let (din, dout) = expected_shape(&topo, &enc, i);
            slots.push(LayerSlot { din, dout, w: off, b: off + din * dout });
            off += din * dout + dout;
        }
        Self { topo, enc, slots, features: None, table: off, n_params: off }
    }

    /// The same network with a learned feature grid of shape `f` (its
    /// `table` is ignored) in front of the trunk; `enc.grid_dim` must be
    /// `f.dim()`.
    pub fn with_features(mut self, f: Option<FeatureGrid<'static>>) -> Self {
        if let Some(mut f) = f {
            assert_eq!(self.enc.grid_dim as usize, f.dim(), "encoding.grid_dim");
            f.table = &[];
            self.n_params = self.table + f.values();
            self.features = Some(f);
        }
        self
    }

    /// Width of the encoded position.
    pub fn pos_dim(&self) -> usize {
        self.enc.pos_dim()
    }

    /// Width of γ(x), the part of the encoded position before the grid values.
    fn gamma_dim(&self) -> usize {
        self.enc.gamma_dim()
    }

    /// Initial feature-grid values: uniform in ±`FEATURE_INIT` (instant-ngp's).
    pub const FEATURE_INIT: f32 = 1e-4;

    fn sigma_idx(&self) -> usize {
        self.topo.depth as usize
    }

    /// Initial parameters: PyTorch's default for `nn.Linear`, weights and
    /// biases uniform in `±1/√in`, from a seeded generator — except the
    /// density bias, set to [`Mlp::SIGMA_BIAS_INIT`].
    ///
    /// Why: trunk activations are ReLU outputs that vary little around their
    /// mean at initialisation, so a random density head is often negative
    /// at every point; the compositor's ReLU then passes no gradient and the
    /// network never starts (seen: a coarse network dead from step 0 while
    /// the fine one trained). A positive start makes space semi-opaque
    /// everywhere and lets the loss carve out the empty parts.
    pub fn init(&self, seed: u64) -> Vec<f32> {
        let mut rng = crate::rng::Rng::new(seed);
        let mut p = vec![0.0; self.n_params];
        for s in &self.slots {
            let bound = 1.0 / (s.din as f32).sqrt();
            for v in &mut p[s.w..s.b + s.dout] {
                *v = (rng.f32() * 2.0 - 1.0) * bound;
            }
        }
        let s = self.slots[self.sigma_idx()];
        p[s.b] = Self::SIGMA_BIAS_INIT;
        for v in &mut p[self.table..] {
            *v = (rng.f32() * 2.0 - 1.0) * Self::FEATURE_INIT;
        }
        p
    }

    /// Feature-grid values (`S × grid_dim`) and corners of `pos`.
    fn grid_forward(&self, p: &[f32], pos: &[[f32; 3]], a: &mut Acts) {
        let Some(f) = &self.features else { return };
        let (w, nl, t) = (f.width as usize, f.levels(), &p[self.table..]);
        let offsets: Vec<usize> = (0..nl).map(|l| f.offset(l)).collect();
        resize(&mut a.gf, pos.len() * nl * w);
        let n = pos.len();
        a.corners.resize(n * nl, Corners::default());
        // level after level: one level's entries stay in cache
        for l in 0..nl {
            for (i, x) in pos.iter().enumerate() {
                let c = f.corners_f32(l, *x);
                c.blend(offsets[l], w, |k| t[k], &mut a.gf[(i * nl + l) * w..(i * nl + l + 1) * w]);
                a.corners[l * n + i] = c;
            }
        }
    }

    /// Scatters `a.dgf` (gradient of the grid values) into the table's gradient.
    fn grid_backward(&self, a: &Acts, g: &mut [f32]) {
        let Some(f) = &self.features else { return };
        let mut gt = &mut g[self.table..];
        for l in 0..f.levels() {
            let (level, rest) = gt.split_at_mut(f.entries(l) * f.width as usize);
            let n = a.s * a.k;
            self.scatter_level(l, &a.corners[l * n..(l + 1) * n], &a.dgf, level);
            gt = rest;
        }
    }

    /// Adds level `l`'s share of a chunk's grid-value gradient (`dgf`,
    /// `P × grid_dim` for its `P` points, `S·k` with `k` footprint points
    /// per sample, with the level's `P` corners from the forward pass)
    /// to `gl`, the gradient of that level's entries (`entries(l) × width`
    /// values). Consecutive samples in the same cell (a ray's samples in a
    /// coarse level) are summed first and written once.
    fn scatter_level(&self, l: usize, corners: &[Corners], dgf: &[f32], gl: &mut [f32]) {
        let Some(f) = &self.features else { return };
        let nl = f.levels();
        per_width!(f.width as usize, W => scatter_level_w::<W>(nl, l, corners, dgf, gl));
    }

    /// Swaps the grid-value gradient of the last [`Mlp::backward_layers`]
    /// into `out`, for [`Mlp::scatter_table`], and `out`'s buffers into
    /// `a` for reuse (`out` holds no samples without a feature grid).
    pub fn swap_grid_grad(&self, a: &mut Acts, out: &mut GridGrad) {
        std::mem::swap(&mut a.corners, &mut out.corners);
        std::mem::swap(&mut a.dgf, &mut out.dgf);
        out.s = if self.features.is_some() { a.s * a.k } else { 0 };
    }

    /// Adds the grid-value gradients of several chunks to `gt`, the
    /// gradient of the feature grid's table (the parameters from
    /// [`Mlp::table`] on): one level per task, chunks in the order given,
    /// so the sums do not depend on the thread count and each task's
    /// writes stay within one level's entries.
    pub fn scatter_table(&self, grads: &[GridGrad], gt: &mut [f32]) {
        let Some(f) = &self.features else { return };
        let mut levels = Vec::with_capacity(f.levels());
        let mut rest = gt;
        for l in 0..f.levels() {
            let (level, r) = rest.split_at_mut(f.entries(l) * f.width as usize);
            levels.push((l, level));
            rest = r;
        }
        levels.into_par_iter().for_each(|(l, gl)| {
            for g in grads {
                self.scatter_level(l, &g.corners[l * g.s..(l + 1) * g.s], &g.dgf, gl);
            }
        });
    }

    /// Initial density bias of bounded scenes (σ in 1/world units before
    /// the ReLU): with the σ head's weights at ±1/√width on activations of
    /// order 1, this keeps σ > 0 at nearly every point at the start.
    pub const SIGMA_BIAS_INIT: f32 = 1.0;

    /// [`Mlp::init`] with the density head's weights at zero and its bias
    /// at `sigma` (1/world units, > 0): the network starts with the same
    /// density `sigma` at every point, whatever the seed, and the head's
    /// weights learn from the first step (their gradient is the trunk's
    /// activations times the density's).
    pub fn init_uniform_density(&self, seed: u64, sigma: f32) -> Vec<f32> {
        debug_assert!(sigma > 0.0 && sigma.is_finite(), "{sigma}");
        let mut p = self.init(seed);
        let s = self.slots[self.sigma_idx()];
        p[s.w..s.w + s.din * s.dout].fill(0.0);
        p[s.b] = sigma;
        p
    }

    /// `out = bias + Σ parts · W[row0..]` for `rows` rows.
    fn linear(&self, p: &[f32], l: usize, parts: &[(&[f32], usize, usize)], rows: usize, out: &mut [f32]) {
        let s = self.slots[l];
        for r in 0..rows {
            out[r * s.dout..(r + 1) * s.dout].copy_from_slice(&p[s.b..s.b + s.dout]);
        }
        for &(x, cols, row0) in parts {
            let w = &p[s.w + row0 * s.dout..s.w + (row0 + cols) * s.dout];
            matmul(rows, s.dout, cols, out, s.dout, true, View::rows(x, cols), View::rows(w, s.dout));
        }
    }

    /// Backward of [`Mlp::linear`] for one input part: accumulates the
    /// weight gradient of rows `row0..row0+cols` and, if `dx` is given,
    /// writes the input gradient (`rows × cols`).
    #[allow(clippy::too_many_arguments)]
    fn linear_back(
        &self,
        p: &[f32],
        g: &mut [f32],
        l: usize,
        x: &[f32],
        cols: usize,
        row0: usize,
        dy: &[f32],
        rows: usize,
        dx: Option<&mut [f32]>,
    ) {
        let s = self.slots[l];
        let gw = &mut g[s.w + row0 * s.dout..s.w + (row0 + cols) * s.dout];
        matmul(cols, s.dout, rows, gw, s.dout, true, View::t(x, cols), View::rows(dy, s.dout));
        if let Some(dx) = dx {
            let w = &p[s.w + row0 * s.dout..s.w + (row0 + cols) * s.dout];
            matmul(rows, cols, s.dout, dx, cols, false, View::rows(dy, s.dout), View::t(w, s.dout));
        }
    }

    fn bias_back(&self, g: &mut [f32], l: usize, dy: &[f32], rows: usize) {
        let s = self.slots[l];
        let gb = &mut g[s.b..s.b + s.dout];
        for r in 0..rows {
            for (a, d) in gb.iter_mut().zip(&dy[r * s.dout..(r + 1) * s.dout]) {
                *a += d;
            }
        }
    }

    /// Forward pass on normalised positions `pos` (`S`) and unit view
    /// directions `dirs` (`R`, one per `S/R` consecutive samples). Fills
    /// `acts.sigma` and, if `need_rgb`, `acts.rgb`: [`Mlp::encode`], then
    /// [`Mlp::forward_layers`].
    pub fn forward(&self, p: &[f32], pos: &[[f32; 3]], dirs: &[[f32; 3]], need_rgb: bool, a: &mut Acts) {
        self.encode(p, pos, a);
        self.forward_layers(p, dirs, need_rgb, a);
    }

    /// The first part of [`Mlp::forward`]: the positions' encoding (γ and
    /// the feature grid's values) into `a`.
    pub fn encode(&self, p: &[f32], pos: &[[f32; 3]], a: &mut Acts) {
        let gd = self.gamma_dim();
        a.s = pos.len();
        a.k = 1;
        resize(&mut a.enc, pos.len() * gd);
        for (i, x) in pos.iter().enumerate() {
            encode_f32(*x, self.enc.pos_freqs as usize, self.enc.include_input, &mut a.enc[i * gd..(i + 1) * gd]);
        }
        self.grid_forward(p, pos, a);
    }

    /// [`Mlp::encode`] with the feature grid's values of sample `i` the
    /// mean of its `K` footprint points `foot[K·i..K·i + K]` (`K` =
    /// [`FOOTPRINT_POINTS`]); γ stays at `pos`. Each point's corners are
    /// kept with their weights divided by `K` (the backward pass scatters
    /// through them); where the points of
    /// a level share one cell (the coarse levels, mostly) their weights are
    /// summed into one set of corners, blended and scattered once (the
    /// others keep the cell with zero weights, which the scatter skips). An
    /// empty `foot`, or a network without a feature grid, is [`Mlp::encode`].
    pub fn encode_footprint(&self, p: &[f32], pos: &[[f32; 3]], foot: &[[f32; 3]], a: &mut Acts) {
        let Some(f) = self.features.as_ref().filter(|_| !foot.is_empty()) else {
            return self.encode(p, pos, a);
        };
        const K: usize = FOOTPRINT_POINTS;
        assert_eq!(foot.len(), K * pos.len(), "{K} footprint points per sample");
        let (gd, s) = (self.gamma_dim(), pos.len());
        resize(&mut a.enc, s * gd);
        for (i, x) in pos.iter().enumerate() {
            encode_f32(*x, self.enc.pos_freqs as usize, self.enc.include_input, &mut a.enc[i * gd..(i + 1) * gd]);
        }
        let (w, nl, t) = (f.width as usize, f.levels(), &p[self.table..]);
        resize(&mut a.gf, s * nl * w);
        a.corners.resize(K * s * nl, Corners::default());
        for l in 0..nl {
            let corners = &mut a.corners[l * K * s..(l + 1) * K * s];
            per_width!(w, W => footprint_level::<W>(f, l, t, foot, &mut a.gf, corners));
        }
        (a.s, a.k) = (s, K);
    }

    /// The rest of [`Mlp::forward`]: the layers on the encoding
    /// [`Mlp::encode`] left in `a`, with the view directions `dirs`.
    pub fn forward_layers(&self, p: &[f32], dirs: &[[f32; 3]], need_rgb: bool, a: &mut Acts) {
        let (s, r) = (a.s, dirs.len());
        let (pd, dd) = (self.enc.pos_dim(), self.enc.dir_dim());
        let (gd, fd) = (self.gamma_dim(), self.enc.grid_dim as usize);
        let w = self.topo.width as usize;
        let d = self.topo.depth as usize;
        a.r = r;
        a.h.resize(d, Vec::new());
        for i in 0..d {
            let mut out = std::mem::take(&mut a.h[i]);
            resize(&mut out, s * w);
            if i == 0 {
                self.linear(p, 0, &[(&a.enc, gd, 0), (&a.gf, fd, gd)], s, &mut out);
            } else if self.topo.is_skip(i) {
                self.linear(p, i, &[(&a.enc, gd, 0), (&a.gf, fd, gd), (&a.h[i - 1], w, pd)], s, &mut out);
            } else {
                self.linear(p, i, &[(&a.h[i - 1], w, 0)], s, &mut out);
            }
            out.iter_mut().for_each(|v| *v = v.max(0.0));
            a.h[i] = out;
        }
        let trunk = &a.h[d - 1];
        resize(&mut a.sigma, s);
        self.linear(p, self.sigma_idx(), &[(trunk, w, 0)], s, &mut a.sigma);
        if !need_rgb {
            return;
        }
        resize(&mut a.rgb, s * 3);
        let si = self.sigma_idx();
        if self.topo.view_dependent {
            let vw = self.topo.view_width as usize;
            resize(&mut a.feat, s * w);
            self.linear(p, si + 1, &[(trunk, w, 0)], s, &mut a.feat);
            resize(&mut a.denc, r * dd);
            for (i, v) in dirs.iter().enumerate() {
                encode_f32(*v, self.enc.dir_freqs as usize, self.enc.include_input, &mut a.denc[i * dd..(i + 1) * dd]);
            }
            let sl = self.slots[si + 2];
            resize(&mut a.dirpart, r * vw);
            let wd = &p[sl.w + w * vw..sl.w + (w + dd) * vw];
            matmul(r, vw, dd, &mut a.dirpart, vw, false, View::rows(&a.denc, dd), View::rows(wd, vw));
            resize(&mut a.view, s * vw);
            self.linear(p, si + 2, &[(&a.feat, w, 0)], s, &mut a.view);
            let spr = s / r;
            for (i, row) in a.view.chunks_exact_mut(vw).enumerate() {
                let dp = &a.dirpart[(i / spr) * vw..(i / spr + 1) * vw];
                for (v, x) in row.iter_mut().zip(dp) {
                    *v = (*v + x).max(0.0);
                }
            }
            self.linear(p, si + 3, &[(&a.view, vw, 0)], s, &mut a.rgb);
        } else {
            self.linear(p, si + 1, &[(trunk, w, 0)], s, &mut a.rgb);
        }
        a.rgb.iter_mut().for_each(|v| *v = 1.0 / (1.0 + (-*v).exp()));
    }

    /// Backward pass: given `dsigma` (`S`) and `drgb` (`3S`, or empty if the
    /// forward skipped colour), accumulates parameter gradients into `g`.
    pub fn backward(&self, p: &[f32], a: &mut Acts, dsigma: &[f32], drgb: &[f32], g: &mut [f32]) {
        self.backward_layers(p, a, dsigma, drgb, &mut g[..self.table]);
        self.grid_backward(a, g);
    }

    /// [`Mlp::backward`] without the feature grid's table: accumulates the
    /// layers' gradients into `g` (the first [`Mlp::table`] parameters) and
    /// leaves the grid values' gradient in `a` ([`Mlp::swap_grid_grad`]).
    pub fn backward_layers(&self, p: &[f32], a: &mut Acts, dsigma: &[f32], drgb: &[f32], g: &mut [f32]) {
        let (s, r) = (a.s, a.r);
        let pd = self.enc.pos_dim();
        let (gd, fd) = (self.gamma_dim(), self.enc.grid_dim as usize);
        let dd = self.enc.dir_dim();
        let w = self.topo.width as usize;
        let d = self.topo.depth as usize;
        let si = self.sigma_idx();
        let mut dh = std::mem::take(&mut a.dh);
        let mut dtmp = std::mem::take(&mut a.dtmp);
        resize(&mut dh, s * w);
        resize(&mut dtmp, s * w);
        let trunk = &a.h[d - 1];
        // Colour branch: gradient into dh (overwritten), or zero.
        if drgb.is_empty() {
            dh.fill(0.0);
        } else {
            let dz: Vec<f32> = drgb.iter().zip(&a.rgb).map(|(g, y)| g * y * (1.0 - y)).collect();
            if self.topo.view_dependent {
                let vw = self.topo.view_width as usize;
                let mut dview = std::mem::take(&mut a.dview);
                resize(&mut dview, s * vw);
                self.linear_back(p, g, si + 3, &a.view, vw, 0, &dz, s, Some(&mut dview));
                self.bias_back(g, si + 3, &dz, s);
                for (dv, v) in dview.iter_mut().zip(&a.view) {
                    if *v <= 0.0 {
                        *dv = 0.0;
                    }
                }
                // per-ray sum for the direction part
                let mut dray = std::mem::take(&mut a.dray);
                resize(&mut dray, r * vw);
                dray.fill(0.0);
                let spr = s / r;
                for (i, row) in dview.chunks_exact(vw).enumerate() {
                    for (acc, x) in dray[(i / spr) * vw..(i / spr + 1) * vw].iter_mut().zip(row) {
                        *acc += x;
                    }
                }
                self.linear_back(p, g, si + 2, &a.denc, dd, w, &dray, r, None);
                self.linear_back(p, g, si + 2, &a.feat, w, 0, &dview, s, Some(&mut dtmp));
                self.bias_back(g, si + 2, &dview, s);
                self.linear_back(p, g, si + 1, trunk, w, 0, &dtmp, s, Some(&mut dh));
                self.bias_back(g, si + 1, &dtmp, s);
                a.dview = dview;
                a.dray = dray;
            } else {
                self.linear_back(p, g, si + 1, trunk, w, 0, &dz, s, Some(&mut dh));
                self.bias_back(g, si + 1, &dz, s);
            }
        }
        // Density head: dh += dσ · Wσᵀ.
        self.linear_back(p, g, si, trunk, w, 0, dsigma, s, None);
        self.bias_back(g, si, dsigma, s);
        let ws = &p[self.slots[si].w..self.slots[si].w + w];
        for (row, ds) in dh.chunks_exact_mut(w).zip(dsigma) {
            for (x, wv) in row.iter_mut().zip(ws) {
                *x += ds * wv;
            }
        }
        // Trunk, last layer first; the grid values' gradient summed over
        // layer 0 and the skip layers.
        let (mut dgf, mut dpart) = (std::mem::take(&mut a.dgf), std::mem::take(&mut a.dgf_part));
        resize(&mut dgf, s * fd);
        resize(&mut dpart, s * fd);
        dgf.fill(0.0);
        for i in (0..d).rev() {
            for (x, h) in dh.iter_mut().zip(&a.h[i]) {
                if *h <= 0.0 {
                    *x = 0.0;
                }
            }
            self.bias_back(g, i, &dh, s);
            if i == 0 || self.topo.is_skip(i) {
                self.linear_back(p, g, i, &a.enc, gd, 0, &dh, s, None);
                if fd > 0 {
                    self.linear_back(p, g, i, &a.gf, fd, gd, &dh, s, Some(&mut dpart));
                    dgf.iter_mut().zip(&dpart).for_each(|(a, b)| *a += b);
                }
            }
            if i == 0 {
                break;
            }
            let row0 = if self.topo.is_skip(i) { pd } else { 0 };
            self.linear_back(p, g, i, &a.h[i - 1], w, row0, &dh, s, Some(&mut dtmp));
            std::mem::swap(&mut dh, &mut dtmp);
        }
        if a.k > 1 {
            // each footprint point's corners carry its share in their weights
            let mut spread = dpart;
            resize(&mut spread, s * a.k * fd);
            for (i, row) in dgf.chunks_exact(fd).enumerate() {
                for m in 0..a.k {
                    let o = (i * a.k + m) * fd;
                    spread[o..o + fd].copy_from_slice(row);
                }
            }
            a.dgf = spread;
            a.dgf_part = dgf;
            a.dh = dh;
            a.dtmp = dtmp;
            return;
        }
        a.dgf = dgf;
        a.dgf_part = dpart;
        a.dh = dh;
        a.dtmp = dtmp;
    }

    /// Raises `max[l]` to the largest |output| of layer `l` in `a` (trunk,
    /// density head, and on the view branch feature and view layers).
    pub fn record_max_abs(&self, a: &Acts, max: &mut [f32]) {
        let m = |v: &[f32]| v.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        let d = self.topo.depth as usize;
        for i in 0..d {
            max[i] = max[i].max(m(&a.h[i]));
        }
        max[d] = max[d].max(m(&a.sigma));
        if self.topo.view_dependent && !a.feat.is_empty() {
            max[d + 1] = max[d + 1].max(m(&a.feat));
            max[d + 2] = max[d + 2].max(m(&a.view));
        }
    }

    /// Marks in `active[l][c]` every ReLU output `c` of layer `l` (trunk and
    /// view layer) that is positive for some sample of `a`; `active` holds
    /// one `Vec` of the layer's width per layer.
    pub fn record_active(&self, a: &Acts, active: &mut [Vec<bool>]) {
        let mark = |v: &[f32], w: usize, act: &mut Vec<bool>| {
            for row in v.chunks_exact(w) {
                for (f, x) in act.iter_mut().zip(row) {
                    *f |= *x > 0.0;
                }
            }
        };
        let d = self.topo.depth as usize;
        for i in 0..d {
            mark(&a.h[i][..a.s * self.slots[i].dout], self.slots[i].dout, &mut active[i]);
        }
        if self.topo.view_dependent && !a.view.is_empty() {
            let vw = self.slots[d + 2].dout;
            mark(&a.view[..a.s * vw], vw, &mut active[d + 2]);
        }
    }

    /// Multiply-accumulates of one forward evaluation (per sample), with
    /// the view layer's direction part counted per sample.
    pub fn macs_per_sample(&self) -> usize {
        self.slots.iter().map(|s| s.din * s.dout).sum()
    }
}

/// Level `l` of [`Mlp::encode_footprint`] for a grid of width `W`: writes
/// each sample's values (in `gf`, `S × levels × W`) as the mean over its
/// `K` footprint points `foot`, and the points' corners (in `corners`, `K`
/// per sample) with their weights divided by `K`. When all `K` points of a
/// sample lie in one cell, their weights are summed into the first slot and
/// blended once, and the other slots are set to that cell with zero weights.
fn footprint_level<const W: usize>(
    f: &FeatureGrid<'_>,
    l: usize,
    t: &[f32],
    foot: &[[f32; 3]],
    gf: &mut [f32],
    corners: &mut [Corners],
) {
    const K: usize = FOOTPRINT_POINTS;
    let (base, nl) = (f.offset(l), f.levels());
    let share = 1.0 / K as f32;
    for (i, (pts, slots)) in foot.chunks_exact(K).zip(corners.chunks_exact_mut(K)).enumerate() {
        let mut c: [Corners; K] = std::array::from_fn(|m| f.corners_f32(l, pts[m]));
        let out = &mut gf[(i * nl + l) * W..][..W];
        if c.iter().all(|k| k.entry == c[0].entry) {
            let weight = std::array::from_fn(|j| share * c.iter().map(|k| k.weight[j]).sum::<f32>());
            let one = Corners { entry: c[0].entry, weight };
            one.blend(base, W, |k| t[k], out);
            slots[0] = one;
            slots[1..].fill(Corners { entry: c[0].entry, weight: [0.0; 8] });
        } else {
            let (mut sum, mut one) = ([0.0f32; W], [0.0f32; W]);
            for (k, slot) in c.iter_mut().zip(slots.iter_mut()) {
                k.weight.iter_mut().for_each(|v| *v *= share);
                k.blend(base, W, |e| t[e], &mut one);
                sum.iter_mut().zip(&one).for_each(|(s, v)| *s += v);
                *slot = *k;
            }
            out.copy_from_slice(&sum);
        }
    }
}

/// [`Mlp::scatter_level`] of a grid of width `W` and `nl` levels.
fn scatter_level_w<const W: usize>(nl: usize, l: usize, corners: &[Corners], dgf: &[f32], gl: &mut [f32]) {
    let mut acc = [[0.0f32; W]; 8];
    let mut cell: Option<[u32; 8]> = None;
    let flush = |entry: &[u32; 8], acc: &mut [[f32; W]; 8], gl: &mut [f32]| {
        for (e, a) in entry.iter().zip(acc.iter_mut()) {
            let g = &mut gl[*e as usize * W..][..W];
            g.iter_mut().zip(a.iter()).for_each(|(g, v)| *g += v);
            *a = [0.0; W];
        }
    };
    for (i, c) in corners.iter().enumerate() {
        // a footprint point merged into its sample's first (zero weights)
        if c.weight == [0.0; 8] {
            continue;
        }
        if cell != Some(c.entry) {
            if let Some(entry) = &cell {
                flush(entry, &mut acc, gl);
            }
            cell = Some(c.entry);
        }
        let d = &dgf[(i * nl + l) * W..][..W];
        for (a, wk) in acc.iter_mut().zip(&c.weight) {
            a.iter_mut().zip(d).for_each(|(a, d)| *a += wk * d);
        }
    }
    if let Some(entry) = &cell {
        flush(entry, &mut acc, gl);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn loss(m: &Mlp, p: &[f32], pos: &[[f32; 3]], foot: &[[f32; 3]], dirs: &[[f32; 3]], a: &mut Acts) -> f64 {
        m.encode_footprint(p, pos, foot, a);
        m.forward_layers(p, dirs, true, a);
        let ls: f64 = a.sigma.iter().enumerate().map(|(i, v)| (*v as f64) * (0.3 + i as f64 * 0.1)).sum();
        let lc: f64 = a.rgb.iter().enumerate().map(|(i, v)| (*v as f64) * ((i % 5) as f64 - 2.0)).sum();
        ls + lc
    }

    fn check_gradients(topo: Topology, enc: Encoding) {
        check_gradients_with(Mlp::new(topo, enc), false);
    }

    /// Finite differences against the backward pass; with `footprint`,
    /// each sample's features are the mean over three points around it.
    fn check_gradients_with(m: Mlp, footprint: bool) {
        let mut p = m.init(3);
        // shift biases so that ReLUs are mostly active away from kinks
        for s in &m.slots {
            for v in &mut p[s.b..s.b + s.dout] {
                *v += 0.05;
            }
        }
        // feature values of the size trained grids reach (init is ±1e-4)
        for (k, v) in p[m.table..].iter_mut().enumerate() {
            *v = (k as f32 * 0.7).sin() * 0.5;
        }
        let pos: Vec<[f32; 3]> = (0..6).map(|i| [0.1 * i as f32, -0.2, 0.05 * i as f32 - 0.1]).collect();
        let dirs = vec![[0.0, 0.6, -0.8], [0.8, 0.0, -0.6]];
        let foot: Vec<[f32; 3]> = match footprint {
            true => pos
                .iter()
                .flat_map(|q| {
                    [[0.13, 0.0, 0.02], [-0.07, 0.11, -0.05], [-0.06, -0.11, 0.03]]
                        .map(|o| [q[0] + o[0], q[1] + o[1], q[2] + o[2]])
                })
                .collect(),
            false => Vec::new(),
        };
        let mut a = Acts::default();
        m.encode_footprint(&p, &pos, &foot, &mut a);
        m.forward_layers(&p, &dirs, true, &mut a);
        let ds: Vec<f32> = (0..6).map(|i| 0.3 + i as f32 * 0.1).collect();
        let dc: Vec<f32> = (0..18).map(|i| (i % 5) as f32 - 2.0).collect();
        let mut g = vec![0.0; m.n_params];
        m.backward(&p, &mut a, &ds, &dc, &mut g);
        // the samples reach table entries of every level (the test must see them)
        if let Some(f) = &m.features {
            for l in 0..f.levels() {
                let w = f.width as usize;
                let level = &g[m.table + f.offset(l) * w..m.table + f.offset(l + 1) * w];
                let touched = level.iter().filter(|v| v.abs() > 1e-3).count();
                assert!(touched >= 8, "{touched} table gradients in level {l}");
            }
        }
        let (mut checked, mut kinks) = (0, 0);
        let fd = |k: usize, h: f32, a: &mut Acts| {
            let mut pp = p.clone();
            pp[k] += h;
            let lp = loss(&m, &pp, &pos, &foot, &dirs, a);
            pp[k] -= 2.0 * h;
            let lm = loss(&m, &pp, &pos, &foot, &dirs, a);
            (lp - lm) / (2.0 * h as f64)
        };
        for k in 0..m.n_params {
            let (f1, f2) = (fd(k, 1e-3, &mut a), fd(k, 5e-4, &mut a));
            let tol = 2e-2 * f1.abs().max(g[k].abs() as f64).max(0.05);
            if (f1 - f2).abs() > tol {
                kinks += 1; // a ReLU switches inside the step: not differentiable there
                continue;
            }
            assert!((f1 - g[k] as f64).abs() <= tol, "param {k}: fd {f1} vs analytic {}", g[k]);
            checked += 1;
        }
        assert!(kinks * 20 < checked, "{kinks} kinks of {checked}");
    }

    #[test]
    fn gradients_match_finite_differences_view_branch_and_skip() {
        let topo = Topology { depth: 3, width: 8, skip_mask: 1 << 2, view_dependent: true, view_width: 4 };
        let enc = Encoding { pos_freqs: 2, dir_freqs: 1, include_input: true, raw_frac_bits: 12, grid_dim: 0 };
        check_gradients(topo, enc);
    }

    #[test]
    fn gradients_match_finite_differences_plain() {
        let topo = Topology { depth: 2, width: 6, skip_mask: 0, view_dependent: false, view_width: 0 };
        let enc = Encoding { pos_freqs: 3, dir_freqs: 0, include_input: false, raw_frac_bits: 12, grid_dim: 0 };
        check_gradients(topo, enc);
    }

    /// A small network with two dense levels and one hashed of `width`
    /// values per entry, a skip layer that also reads them.
    fn with_feature_grid(width: u8) -> Mlp {
        let topo = Topology { depth: 3, width: 8, skip_mask: 1 << 2, view_dependent: true, view_width: 4 };
        let f = FeatureGrid {
            width,
            log2_table: 5,
            frac_bits: 0,
            resolutions: nerf_infer::features::geometric_resolutions(3, 1, 5),
            table: &[],
            narrow: None,
        };
        let enc = Encoding { pos_freqs: 1, dir_freqs: 1, include_input: true, raw_frac_bits: 12, grid_dim: 3 * width };
        let m = Mlp::new(topo, enc).with_features(Some(f));
        // levels of 1, 2 and 5 cells: 8 and 27 vertices (dense), 216 > 32 (hashed)
        assert_eq!(m.n_params, m.table + (8 + 27 + 32) * width as usize);
        m
    }

    #[test]
    fn gradients_match_finite_differences_with_a_feature_grid() {
        check_gradients_with(with_feature_grid(2), false);
    }

    #[test]
    fn gradients_match_finite_differences_with_footprint_means_of_the_features() {
        check_gradients_with(with_feature_grid(2), true);
    }

    #[test]
    fn gradients_match_finite_differences_at_feature_widths_3_4_and_8() {
        // the feature loops are compiled once per width: an odd one,
        // another even one and the widest, with and without footprints
        for width in [3, 4, 8] {
            for footprint in [false, true] {
                check_gradients_with(with_feature_grid(width), footprint);
            }
        }
    }

    #[test]
    fn the_table_scattered_from_chunks_equals_the_backward_of_each_chunk_in_turn() {
        scatter_equals_backward(false);
    }

    #[test]
    fn the_table_scattered_from_chunks_with_footprints_equals_their_backward() {
        scatter_equals_backward(true);
    }

    fn scatter_equals_backward(footprint: bool) {
        let topo = Topology { depth: 2, width: 8, skip_mask: 0, view_dependent: true, view_width: 4 };
        let f = FeatureGrid {
            width: 2,
            log2_table: 6,
            frac_bits: 0,
            resolutions: nerf_infer::features::geometric_resolutions(3, 2, 9),
            table: &[],
            narrow: None,
        };
        let enc = Encoding { pos_freqs: 0, dir_freqs: 1, include_input: true, raw_frac_bits: 12, grid_dim: 6 };
        let m = Mlp::new(topo, enc).with_features(Some(f));
        let mut p = m.init(5);
        for (k, v) in p[m.table..].iter_mut().enumerate() {
            *v = (k as f32 * 0.3).cos() * 0.4;
        }
        let dirs = [[0.0, 0.6, -0.8], [0.8, 0.0, -0.6]];
        let chunks: Vec<Vec<[f32; 3]>> = (0..3)
            .map(|c| (0..8).map(|i| [0.11 * i as f32 - 0.4, 0.07 * c as f32 - 0.2, 0.3 - 0.09 * i as f32]).collect())
            .collect();
        let ds: Vec<f32> = (0..8).map(|i| 0.2 + i as f32 * 0.1).collect();
        let dc: Vec<f32> = (0..24).map(|i| (i % 7) as f32 - 3.0).collect();
        // every chunk's full backward into one gradient, in turn
        let mut whole = vec![0.0; m.n_params];
        let (mut layers, mut grads) = (vec![0.0; m.table], Vec::new());
        let mut a = Acts::default();
        for pos in &chunks {
            let foot: Vec<[f32; 3]> = match footprint {
                true => pos.iter().flat_map(|q| [0.05f32, -0.03, 0.08].map(|o| [q[0] + o, q[1] - o, q[2]])).collect(),
                false => Vec::new(),
            };
            m.encode_footprint(&p, pos, &foot, &mut a);
            m.forward_layers(&p, &dirs, true, &mut a);
            m.backward(&p, &mut a, &ds, &dc, &mut whole);
            m.encode_footprint(&p, pos, &foot, &mut a);
            m.forward_layers(&p, &dirs, true, &mut a);
            m.backward_layers(&p, &mut a, &ds, &dc, &mut layers);
            let mut gg = GridGrad::default();
            m.swap_grid_grad(&mut a, &mut gg);
            grads.push(gg);
        }
        let mut table = vec![0.0; m.n_params - m.table];
        m.scatter_table(&grads, &mut table);
        assert!(table.iter().filter(|v| **v != 0.0).count() > 20);
        assert_eq!(&whole[..m.table], &layers[..]);
        assert_eq!(&whole[m.table..], &table[..]);
    }
}
