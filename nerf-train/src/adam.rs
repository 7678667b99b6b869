//! Adam (Kingma & Ba) with bias correction, as the paper trains with; for
//! a feature grid's table, instant-ngp's sparse form: only the entries a
//! step touched are updated, each with its own step count.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Adam's moment estimates and step counts.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Adam {
    /// First moments.
    pub m: Vec<f32>,
    /// Second moments.
    pub v: Vec<f32>,
    /// Updates applied ([`Adam::update`]).
    pub t: u64,
    /// Updates applied to each table entry ([`Adam::update_entries`]), all
    /// levels in turn; empty without a table.
    pub entry_steps: Vec<u32>,
    /// Bias corrections by step count, for [`Adam::update_entries`].
    #[serde(skip)]
    bias: BiasCorrections,
}

/// `1 − βᵏ` of both moments for `k = 1..`, up to the step past which both
/// round to 1 in f32 (at most a million steps; later ones are computed).
#[derive(Clone, Debug, Default)]
struct BiasCorrections {
    betas: (f32, f32),
    by_step: Vec<(f32, f32)>,
}

impl BiasCorrections {
    /// The corrections after `k ≥ 1` updates, as [`Adam::update`] computes them.
    fn at(&self, k: u32) -> (f32, f32) {
        let (b1, b2) = self.betas;
        self.by_step.get(k as usize - 1).copied().unwrap_or_else(|| (correction(b1, k), correction(b2, k)))
    }

    fn fit(&mut self, b1: f32, b2: f32) {
        if self.betas == (b1, b2) && !self.by_step.is_empty() {
            return;
        }
        // 1 − βᵏ is exactly 1 in f32 once βᵏ < 2⁻²⁵
        let last = |b: f32| if b <= 0.0 { 1.0 } else { (-25.0 * 2f64.ln() / (b as f64).ln()).ceil() + 1.0 };
        let n = last(b1).max(last(b2)).min(1e6) as u32;
        self.by_step = (1..=n).map(|k| (correction(b1, k), correction(b2, k))).collect();
        self.betas = (b1, b2);
    }
}

/// `1 − βᵏ` in f32, as [`Adam::update`] computes it.
fn correction(b: f32, k: u32) -> f32 {
    1.0 - (b as f64).powi(k.min(i32::MAX as u32) as i32) as f32
}

/// The gradient of a feature grid's table where a step touched it: every
/// value's slot (zero outside the listed entries) and, per level, the
/// entries that received a gradient, each once.
#[derive(Clone, Debug, Default)]
pub struct TableGrad {
    /// Gradient of each table value, `Σ entries × width` (the layout of the
    /// parameters from [`crate::mlp::Mlp::table`] on).
    pub values: Vec<f32>,
    /// Per level, the indices (within the level) of the entries touched,
    /// in the order first touched.
    pub touched: Vec<Vec<u32>>,
    /// Per entry of every level: listed in `touched`.
    listed: Vec<bool>,
    /// Entries of each level.
    entries: Vec<usize>,
    /// Values per entry.
    width: usize,
}

/// One level's part of a [`TableGrad`]: its values' gradient, its entries'
/// flags and its list of touched entries.
pub struct LevelGrad<'a> {
    /// Gradient of the level's values (`entries × width`).
    pub values: &'a mut [f32],
    /// Per entry: already in `touched`.
    pub listed: &'a mut [bool],
    /// The level's touched entries.
    pub touched: &'a mut Vec<u32>,
}

impl LevelGrad<'_> {
    /// Adds `g` (one value per `width`) to entry `e`, listing it if new.
    #[inline]
    pub fn add(&mut self, e: usize, g: &[f32]) {
        if !self.listed[e] {
            self.listed[e] = true;
            self.touched.push(e as u32);
        }
        let w = g.len();
        self.values[e * w..(e + 1) * w].iter_mut().zip(g).for_each(|(a, v)| *a += v);
    }
}

impl TableGrad {
    /// An empty gradient of a table of `entries[l]` entries per level, `width` values each.
    pub fn new(entries: Vec<usize>, width: usize) -> Self {
        let total: usize = entries.iter().sum();
        Self {
            values: vec![0.0; total * width],
            touched: vec![Vec::new(); entries.len()],
            listed: vec![false; total],
            entries,
            width,
        }
    }

    /// Entries per level.
    pub fn entries(&self) -> &[usize] {
        &self.entries
    }

    /// Values per entry.
    pub fn width(&self) -> usize {
        self.width
    }

    /// The levels' parts, to fill in parallel.
    pub fn levels(&mut self) -> Vec<LevelGrad<'_>> {
        let (mut values, mut listed) = (&mut self.values[..], &mut self.listed[..]);
        let mut out = Vec::with_capacity(self.entries.len());
        for (&n, touched) in self.entries.iter().zip(self.touched.iter_mut()) {
            let (v, rv) = values.split_at_mut(n * self.width);
            let (f, rf) = listed.split_at_mut(n);
            out.push(LevelGrad { values: v, listed: f, touched });
            (values, listed) = (rv, rf);
        }
        out
    }

    /// Whether every listed value is finite.
    pub fn is_finite(&self) -> bool {
        let mut start = 0;
        self.entries.iter().zip(&self.touched).all(|(&n, t)| {
            let w = self.width;
            let ok = t.iter().all(|&e| {
                let i = (start + e as usize) * w;
                self.values[i..i + w].iter().all(|v| v.is_finite())
            });
            start += n;
            ok
        })
    }

    /// Zeroes the listed values and empties the lists, for the next step.
    pub fn clear(&mut self) {
        let w = self.width;
        self.levels().into_par_iter().for_each(|l| {
            for &e in l.touched.iter() {
                l.listed[e as usize] = false;
                l.values[e as usize * w..(e as usize + 1) * w].fill(0.0);
            }
            l.touched.clear();
        });
    }
}

impl Adam {
    /// Zeroed state for `n` parameters, of which the last `Σ table_entries
    /// × width` are a feature grid's table (`table_entries`: entries per
    /// level; empty without a table).
    pub fn new(n: usize, table_entries: &[usize]) -> Self {
        Self {
            m: vec![0.0; n],
            v: vec![0.0; n],
            t: 0,
            entry_steps: vec![0; table_entries.iter().sum()],
            bias: BiasCorrections::default(),
        }
    }

    /// One update of the first `g.len()` parameters (`p` holds exactly
    /// those): `m ← β₁m + (1−β₁)g`, `v ← β₂v + (1−β₂)g²`,
    /// `p ← p − lr·m̂/(√v̂ + ε)` with `m̂ = m/(1−β₁ᵗ)`, `v̂ = v/(1−β₂ᵗ)`.
    pub fn update(&mut self, p: &mut [f32], g: &[f32], lr: f32, b1: f32, b2: f32, eps: f32) {
        assert!(p.len() == g.len() && g.len() <= self.m.len(), "{} parameters, {} gradients", p.len(), g.len());
        self.t += 1;
        let k = self.t.min(u32::MAX as u64) as u32;
        let (bc1, bc2) = (correction(b1, k), correction(b2, k));
        // element-wise: split in blocks across threads (a feature grid's
        // table makes millions of parameters)
        const BLOCK: usize = 1 << 16;
        let (m, v) = (&mut self.m[..g.len()], &mut self.v[..g.len()]);
        let blocks = p.par_chunks_mut(BLOCK).zip(g.par_chunks(BLOCK)).zip(m.par_chunks_mut(BLOCK));
        blocks.zip(v.par_chunks_mut(BLOCK)).for_each(|(((p, g), m), v)| {
            for (((p, g), m), v) in p.iter_mut().zip(g).zip(m).zip(v) {
                *m = b1 * *m + (1.0 - b1) * g;
                *v = b2 * *v + (1.0 - b2) * g * g;
                *p -= lr * (*m / bc1) / ((*v / bc2).sqrt() + eps);
            }
        });
    }

    /// [`Adam::update`] of the table's touched entries only (instant-ngp's
    /// optimiser for its hash tables): `table` holds the table's parameters
    /// (the last ones); each touched entry's values take one step with the
    /// bias correction of the entry's own count of updates, the others keep
    /// their value and moments (dense Adam would keep moving an entry for
    /// tens of steps after its last gradient, on momentum alone).
    pub fn update_entries(&mut self, table: &mut [f32], g: &TableGrad, lr: f32, b1: f32, b2: f32, eps: f32) {
        let w = g.width();
        let n = table.len();
        assert!(n == g.values.len() && n <= self.m.len(), "{n} table values, {} gradients", g.values.len());
        assert_eq!(self.entry_steps.len() * w, n, "entry counts for {} entries", self.entry_steps.len());
        self.bias.fit(b1, b2);
        let from = self.m.len() - n;
        let (mut p, mut m, mut v) = (table, &mut self.m[from..], &mut self.v[from..]);
        let (mut steps, mut values) = (&mut self.entry_steps[..], &g.values[..]);
        let mut levels = Vec::with_capacity(g.entries().len());
        for (&ne, touched) in g.entries().iter().zip(&g.touched) {
            let (pl, rp) = std::mem::take(&mut p).split_at_mut(ne * w);
            let (ml, rm) = std::mem::take(&mut m).split_at_mut(ne * w);
            let (vl, rv) = std::mem::take(&mut v).split_at_mut(ne * w);
            let (sl, rs) = std::mem::take(&mut steps).split_at_mut(ne);
            let (gl, rg) = values.split_at(ne * w);
            levels.push((pl, ml, vl, sl, gl, touched));
            (p, m, v, steps, values) = (rp, rm, rv, rs, rg);
        }
        let bias = &self.bias;
        levels.into_par_iter().for_each(|(p, m, v, steps, g, touched)| {
            for &e in touched {
                let e = e as usize;
                steps[e] = steps[e].saturating_add(1);
                let (bc1, bc2) = bias.at(steps[e]);
                for i in e * w..(e + 1) * w {
                    m[i] = b1 * m[i] + (1.0 - b1) * g[i];
                    v[i] = b2 * v[i] + (1.0 - b2) * g[i] * g[i];
                    p[i] -= lr * (m[i] / bc1) / ((v[i] / bc2).sqrt() + eps);
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_steps_match_hand_computation() {
        // With a constant gradient, m̂ = g and v̂ = g², so every step moves by lr·g/(|g|+ε).
        let mut a = Adam::new(2, &[]);
        let mut p = [1.0f32, -2.0];
        for k in 1..=10 {
            a.update(&mut p, &[0.5, -4.0], 0.01, 0.9, 0.999, 1e-8);
            assert!((p[0] - (1.0 - 0.01 * k as f32)).abs() < 1e-5, "step {k}: {}", p[0]);
            assert!((p[1] - (-2.0 + 0.01 * k as f32)).abs() < 1e-5);
        }
        assert_eq!(a.t, 10);
    }

    #[test]
    fn entries_touched_every_step_follow_the_dense_update() {
        // 2 levels of 3 and 2 entries, 2 values each, after 4 layer parameters
        let (entries, w) = (vec![3, 2], 2);
        let mut dense = Adam::new(4 + 10, &entries);
        let mut sparse = dense.clone();
        let mut p = vec![0.5f32; 14];
        let mut q = p.clone();
        let mut tg = TableGrad::new(entries, w);
        for k in 0..40 {
            let g: Vec<f32> = (0..14).map(|i| ((i * 7 + k * 3) % 11) as f32 * 0.1 - 0.5).collect();
            dense.update(&mut p, &g, 0.01, 0.9, 0.99, 1e-15);
            {
                let mut levels = tg.levels();
                for (l, level) in levels.iter_mut().enumerate() {
                    let (first, n) = if l == 0 { (0, 3) } else { (3, 2) };
                    for e in (0..n).rev() {
                        level.add(e, &g[4 + (first + e) * w..4 + (first + e + 1) * w]);
                    }
                }
            }
            let (layers, table) = q.split_at_mut(4);
            sparse.update(layers, &g[..4], 0.01, 0.9, 0.99, 1e-15);
            sparse.update_entries(table, &tg, 0.01, 0.9, 0.99, 1e-15);
            tg.clear();
        }
        assert_eq!(p, q);
        assert_eq!(sparse.entry_steps, vec![40; 5]);
    }

    #[test]
    fn entries_without_a_gradient_keep_their_value_and_moments() {
        let mut a = Adam::new(8, &[4]);
        let mut table = vec![1.0f32; 8];
        let mut tg = TableGrad::new(vec![4], 2);
        tg.levels()[0].add(2, &[0.5, -0.5]);
        a.update_entries(&mut table, &tg, 0.01, 0.9, 0.99, 1e-15);
        tg.clear();
        tg.levels()[0].add(1, &[0.25, 0.25]);
        a.update_entries(&mut table, &tg, 0.01, 0.9, 0.99, 1e-15);
        // each touched entry took one first step of lr·sign(g); entries 0 and 3 never moved
        let want = [1.0, 1.0, 0.99, 0.99, 0.99, 1.01, 1.0, 1.0];
        for (t, w) in table.iter().zip(want) {
            assert!((t - w).abs() < 1e-6, "{table:?}");
        }
        assert_eq!(a.entry_steps, vec![0, 1, 1, 0]);
        assert_eq!((a.m[0], a.v[7], a.t), (0.0, 0.0, 0));
        assert!(tg.is_finite());
        tg.levels()[0].add(3, &[f32::NAN, 0.0]);
        assert!(!tg.is_finite());
    }

    #[test]
    fn bias_corrections_match_the_dense_formula_past_the_table() {
        let mut b = BiasCorrections::default();
        b.fit(0.9, 0.999);
        let n = b.by_step.len() as u32;
        assert!(n > 17_000 && n < 17_400, "{n}");
        for k in [1, 2, 100, n - 1, n, n + 1, 10 * n] {
            assert_eq!(b.at(k), (correction(0.9, k), correction(0.999, k)), "step {k}");
        }
        assert_eq!(b.at(n + 1), (1.0, 1.0));
    }

    #[test]
    fn minimises_a_quadratic() {
        let mut a = Adam::new(1, &[]);
        let mut p = [3.0f32];
        for _ in 0..2000 {
            let g = [2.0 * (p[0] - 1.5)];
            a.update(&mut p, &g, 0.01, 0.9, 0.999, 1e-8);
        }
        assert!((p[0] - 1.5).abs() < 1e-2);
    }
}
