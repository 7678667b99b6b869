//! Adam (Kingma & Ba) with bias correction, as the paper trains with; a
//! feature grid's table as tiny-cuda-nn trains instant-ngp's hash tables:
//! a value whose gradient is zero is not updated, and each value counts its
//! own updates for the bias correction.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Adam's moment estimates and step counts.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Adam {
    /// First moments.
    pub m: Vec<f32>,
    /// Second moments.
    pub v: Vec<f32>,
    /// Updates applied.
    pub t: u64,
    /// Updates applied to each of the last `steps.len()` parameters (a
    /// feature grid's table; empty without one): those with a zero
    /// gradient are skipped.
    pub steps: Vec<u32>,
    /// Bias corrections by step count, for the table's parameters.
    #[serde(skip)]
    bias: BiasCorrections,
}

/// `1 − βᵏ` of both moments for `k = 1..`, up to the step past which both
/// round to 1 in f32 (at most a million steps; later ones are computed).
#[derive(Clone, Debug, Default)]
struct BiasCorrections {
    betas: (f32, f32),
    by_step: Vec<(f32, f32)>,
    /// Whether `by_step` stops before both corrections reach 1.
    capped: bool,
}

impl BiasCorrections {
    /// The corrections after `k ≥ 1` updates, as [`Adam::update`] computes them.
    fn at(&self, k: u32) -> (f32, f32) {
        let (b1, b2) = self.betas;
        match self.by_step.get(k as usize - 1) {
            Some(&c) => c,
            None if self.capped => (correction(b1, k), correction(b2, k)),
            None => (1.0, 1.0),
        }
    }

    fn fit(&mut self, b1: f32, b2: f32) {
        if self.betas == (b1, b2) && !self.by_step.is_empty() {
            return;
        }
        // 1 − βᵏ is exactly 1 in f32 once βᵏ < 2⁻²⁵
        let last = |b: f32| if b <= 0.0 { 1.0 } else { (-25.0 * 2f64.ln() / (b as f64).ln()).ceil() + 1.0 };
        let n = last(b1).max(last(b2));
        self.capped = n > 1e6;
        self.by_step = (1..=n.min(1e6) as u32).map(|k| (correction(b1, k), correction(b2, k))).collect();
        self.betas = (b1, b2);
    }
}

/// One parameter's update with gradient `g` and bias corrections `bc`
/// (`1 − β₁ᵗ`, `1 − β₂ᵗ`) at rates `h`: the moments, then the parameter.
#[inline(always)]
fn step(p: &mut f32, g: f32, m: &mut f32, v: &mut f32, bc: (f32, f32), h: Hyper) {
    let Hyper { lr, b1, b2, eps } = h;
    *m = b1 * *m + (1.0 - b1) * g;
    *v = b2 * *v + (1.0 - b2) * g * g;
    *p -= lr * (*m / bc.0) / ((*v / bc.1).sqrt() + eps);
}

/// `1 − βᵏ` in f32, as [`Adam::update`] computes it for its step count.
fn correction(b: f32, k: u32) -> f32 {
    1.0 - (b as f64).powi(k.min(i32::MAX as u32) as i32) as f32
}

impl Adam {
    /// Zeroed state for `n` parameters, of which the last `sparse` (a
    /// feature grid's table) are updated only where their gradient is not
    /// zero.
    ///
    /// # Panics
    /// If `sparse` is above `n`.
    pub fn new(n: usize, sparse: usize) -> Self {
        assert!(sparse <= n, "{sparse} of {n} parameters");
        Self { m: vec![0.0; n], v: vec![0.0; n], t: 0, steps: vec![0; sparse], bias: BiasCorrections::default() }
    }

    /// One update: `m ← β₁m + (1−β₁)g`, `v ← β₂v + (1−β₂)g²`,
    /// `p ← p − lr·m̂/(√v̂ + ε)` with `m̂ = m/(1−β₁ᵗ)`, `v̂ = v/(1−β₂ᵗ)`;
    /// for the last `steps.len()` parameters only where `g ≠ 0`, with their
    /// own `t` (an entry of the table that no ray reached keeps its
    /// moments, and its value but for the decay, where the dense update
    /// would keep moving it for tens of steps on momentum alone). First,
    /// `table_decay` λ (AdamW's decoupled weight decay; 0: off) scales every
    /// table parameter by `1 − lr·λ`, reached by a ray or not. Leaves `g`
    /// zeroed, ready for the next step's sum (a table's gradient is tens of
    /// megabytes, mostly zeros: only the values read as non-zero are written).
    ///
    /// # Panics
    /// If `p` or `g` does not hold the `n` values of [`Adam::new`].
    #[allow(clippy::too_many_arguments)]
    pub fn update(&mut self, p: &mut [f32], g: &mut [f32], lr: f32, b1: f32, b2: f32, eps: f32, table_decay: f32) {
        self.update_averaged(p, g, lr, b1, b2, eps, table_decay, None);
    }

    /// [`Adam::update`], then with `average` `(a, b)` each parameter folded
    /// into its moving average in the same pass: `a ← a + (1 − b)(p − a)`
    /// (`b` in [0, 1]; `a` holds as many values as `p`). The same values as
    /// the update followed by a separate pass, in one parallel sweep over
    /// the parameters (a feature grid's table makes tens of megabytes);
    /// leaves `g` zeroed.
    ///
    /// # Panics
    /// If `p` or `g` does not hold the `n` values of [`Adam::new`], or `a` as many as `p`.
    #[allow(clippy::too_many_arguments)]
    pub fn update_averaged(
        &mut self,
        p: &mut [f32],
        g: &mut [f32],
        lr: f32,
        b1: f32,
        b2: f32,
        eps: f32,
        table_decay: f32,
        average: Option<(&mut [f32], f32)>,
    ) {
        assert!(p.len() == self.m.len() && g.len() == self.m.len(), "{} parameters, {} gradients", p.len(), g.len());
        self.t += 1;
        let k = self.t.min(u32::MAX as u64) as u32;
        let bc = (correction(b1, k), correction(b2, k));
        let from = self.m.len() - self.steps.len();
        let (average, b) = match average {
            Some((a, b)) => {
                assert_eq!(a.len(), p.len(), "an average of every parameter");
                (Some(a), b)
            }
            None => (None, 1.0),
        };
        // element-wise: split in blocks across threads (a feature grid's
        // table makes millions of parameters)
        const BLOCK: usize = 1 << 16;
        let (p, ps) = p.split_at_mut(from);
        let (g, gs) = g.split_at_mut(from);
        let (m, ms) = self.m.split_at_mut(from);
        let (v, vs) = self.v.split_at_mut(from);
        let (a, a_s) = match average {
            Some(a) => {
                let (x, y) = a.split_at_mut(from);
                (blocks_of(Some(x), p.len(), BLOCK), blocks_of(Some(y), ps.len(), BLOCK))
            }
            None => (blocks_of(None, p.len(), BLOCK), blocks_of(None, ps.len(), BLOCK)),
        };
        let h = Hyper { lr, b1, b2, eps };
        let blocks = p.par_chunks_mut(BLOCK).zip(g.par_chunks_mut(BLOCK)).zip(m.par_chunks_mut(BLOCK));
        blocks.zip(v.par_chunks_mut(BLOCK)).zip(a).for_each(|((((p, g), m), v), a)| {
            dense_block(p, g, m, v, bc, h);
            fold(p, a, b);
        });
        if self.steps.is_empty() {
            return;
        }
        self.bias.fit(b1, b2);
        let bias = &self.bias;
        let keep = 1.0 - lr * table_decay;
        let blocks = ps.par_chunks_mut(BLOCK).zip(gs.par_chunks_mut(BLOCK)).zip(ms.par_chunks_mut(BLOCK));
        let blocks = blocks.zip(vs.par_chunks_mut(BLOCK)).zip(self.steps.par_chunks_mut(BLOCK));
        blocks.zip(a_s).for_each(|(((((p, g), m), v), steps), a)| {
            if keep != 1.0 {
                p.iter_mut().for_each(|p| *p *= keep);
            }
            sparse_block(p, g, m, v, steps, bias, h);
            fold(p, a, b);
        });
    }
}

/// Adam's rates: the step `lr`, the moments' decays `b1`, `b2` and `eps`.
#[derive(Clone, Copy)]
struct Hyper {
    lr: f32,
    b1: f32,
    b2: f32,
    eps: f32,
}

// The blocks' loops are functions of their own (not inlined into the
// parallel closures): inlined, the table's loop compiled to slower code
// for the same arithmetic (`scripts/check/step_ab.sh`, docs/EXPERIMENTS.md).

/// One block of dense parameters' updates with bias corrections `bc`;
/// zeroes the block's gradient.
#[inline(never)]
fn dense_block(p: &mut [f32], g: &mut [f32], m: &mut [f32], v: &mut [f32], bc: (f32, f32), h: Hyper) {
    for (((p, g), m), v) in p.iter_mut().zip(g.iter_mut()).zip(m.iter_mut()).zip(v.iter_mut()) {
        step(p, std::mem::take(g), m, v, bc, h);
    }
}

/// One block of a table's updates: a parameter with a zero gradient is
/// skipped, the others count their updates in `steps`, take their own
/// bias corrections and have their gradient zeroed.
#[inline(never)]
fn sparse_block(
    p: &mut [f32],
    g: &mut [f32],
    m: &mut [f32],
    v: &mut [f32],
    steps: &mut [u32],
    bias: &BiasCorrections,
    h: Hyper,
) {
    for ((((p, g), m), v), k) in p.iter_mut().zip(g.iter_mut()).zip(m.iter_mut()).zip(v.iter_mut()).zip(steps) {
        if *g == 0.0 {
            continue;
        }
        *k = k.saturating_add(1);
        step(p, std::mem::take(g), m, v, bias.at(*k), h);
    }
}

/// Folds a block of parameters `p` into their moving average `a` (when
/// kept): `a ← a + (1 − b)(p − a)`.
#[inline(never)]
fn fold(p: &[f32], a: Option<&mut [f32]>, b: f32) {
    if let Some(a) = a {
        a.iter_mut().zip(p).for_each(|(a, &p)| *a += (1.0 - b) * (p - *a));
    }
}

/// `values` (when given, `len` of them) in blocks of `block`, or as many
/// `None`s as `len` makes blocks: one item per block of the parameters.
fn blocks_of(values: Option<&mut [f32]>, len: usize, block: usize) -> Vec<Option<&mut [f32]>> {
    match values {
        Some(v) => v.chunks_mut(block).map(Some).collect(),
        None => (0..len.div_ceil(block)).map(|_| None).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_steps_match_hand_computation() {
        // With a constant gradient, m̂ = g and v̂ = g², so every step moves by lr·g/(|g|+ε).
        let mut a = Adam::new(2, 0);
        let mut p = [1.0f32, -2.0];
        for k in 1..=10 {
            a.update(&mut p, &mut [0.5, -4.0], 0.01, 0.9, 0.999, 1e-8, 0.0);
            assert!((p[0] - (1.0 - 0.01 * k as f32)).abs() < 1e-5, "step {k}: {}", p[0]);
            assert!((p[1] - (-2.0 + 0.01 * k as f32)).abs() < 1e-5);
        }
        assert_eq!(a.t, 10);
    }

    #[test]
    fn table_values_with_a_gradient_every_step_follow_the_dense_update() {
        let (mut dense, mut sparse) = (Adam::new(12, 0), Adam::new(12, 8));
        let (mut p, mut q) = (vec![0.5f32; 12], vec![0.5f32; 12]);
        for k in 0..3000 {
            // never exactly zero
            let mut g: Vec<f32> = (0..12).map(|i| ((i * 7 + k * 3) % 11) as f32 * 0.1 - 0.55).collect();
            let mut h = g.clone();
            dense.update(&mut p, &mut g, 0.01, 0.9, 0.99, 1e-15, 0.0);
            sparse.update(&mut q, &mut h, 0.01, 0.9, 0.99, 1e-15, 0.0);
            assert!(g.iter().chain(&h).all(|&g| g == 0.0), "the gradients are left zeroed");
        }
        assert_eq!(p, q);
        assert_eq!(sparse.steps, vec![3000; 8]);
    }

    #[test]
    fn table_values_without_a_gradient_keep_their_value_and_moments() {
        let mut a = Adam::new(6, 4);
        let mut p = vec![1.0f32; 6];
        a.update(&mut p, &mut [0.1, 0.1, 0.5, 0.0, 0.0, -0.5], 0.01, 0.9, 0.99, 1e-15, 0.0);
        let after_one = p.clone();
        a.update(&mut p, &mut [0.1, 0.1, 0.0, 0.25, 0.0, 0.0], 0.01, 0.9, 0.99, 1e-15, 0.0);
        // each value's first update moves it by lr·sign(g); the layers' values
        // (the first two) move on every step, table value 4 never did
        assert_eq!(a.steps, vec![1, 1, 0, 1]);
        assert_eq!((p[2], p[5]), (after_one[2], after_one[5]), "no gradient, no move");
        for (got, want) in p[2..].iter().zip([0.99, 0.99, 1.0, 1.01]) {
            assert!((got - want).abs() < 1e-6, "{p:?}");
        }
        assert_eq!((a.m[4], a.v[4]), (0.0, 0.0));
        assert!(p[0] < after_one[0], "the layers keep their momentum");
    }

    #[test]
    fn table_decay_scales_every_table_value_and_no_layer_value() {
        let mut a = Adam::new(4, 2);
        let mut p = vec![1.0f32; 4];
        a.update(&mut p, &mut [0.0, 0.0, 0.0, 0.25], 0.1, 0.9, 0.99, 1e-15, 0.5);
        // layers: no gradient, no move; table: × (1 − 0.1·0.5), then Adam's step
        assert_eq!(&p[..3], &[1.0, 1.0, 0.95]);
        assert!((p[3] - (0.95 - 0.1)).abs() < 1e-6, "{p:?}");
        assert_eq!(a.steps, vec![0, 1]);
    }

    #[test]
    fn bias_corrections_match_the_dense_formula_past_the_table() {
        let mut b = BiasCorrections::default();
        b.fit(0.9, 0.999);
        let n = b.by_step.len() as u32;
        assert!(n > 17_000 && n < 17_400 && !b.capped, "{n}");
        for k in [1, 2, 100, n - 1, n, n + 1, 10 * n] {
            assert_eq!(b.at(k), (correction(0.9, k), correction(0.999, k)), "step {k}");
        }
        assert_eq!(b.at(n + 1), (1.0, 1.0));
    }

    #[test]
    fn the_folded_average_is_the_update_then_the_average() {
        // more values than a block, a table among them, some gradients zero
        let n = (1 << 16) + 1000;
        let (mut fused, mut apart) = (Adam::new(n, n - 300), Adam::new(n, n - 300));
        let mut p: Vec<f32> = (0..n).map(|i| (i % 13) as f32 * 0.1).collect();
        let mut q = p.clone();
        let (mut a, mut b) = (p.clone(), p.clone());
        for k in 0..5 {
            let mut g: Vec<f32> =
                (0..n).map(|i| if (i + k) % 3 == 0 { 0.0 } else { ((i * 7 + k) % 11) as f32 - 5.0 }).collect();
            let mut h = g.clone();
            let d = 0.9 - 0.1 * k as f32;
            fused.update_averaged(&mut p, &mut g, 0.01, 0.9, 0.99, 1e-15, 0.5, Some((&mut a, d)));
            apart.update(&mut q, &mut h, 0.01, 0.9, 0.99, 1e-15, 0.5);
            assert!(g.iter().chain(&h).all(|&g| g == 0.0), "the gradients are left zeroed");
            b.iter_mut().zip(&q).for_each(|(b, &q)| *b += (1.0 - d) * (q - *b));
        }
        assert_eq!(p, q);
        assert_eq!(a, b);
        assert_eq!(fused.steps, apart.steps);
        assert_ne!(a, p, "the average lags the parameters");
    }

    #[test]
    fn minimises_a_quadratic() {
        let mut a = Adam::new(1, 0);
        let mut p = [3.0f32];
        for _ in 0..2000 {
            let mut g = [2.0 * (p[0] - 1.5)];
            a.update(&mut p, &mut g, 0.01, 0.9, 0.999, 1e-8, 0.0);
        }
        assert!((p[0] - 1.5).abs() < 1e-2);
    }
}
