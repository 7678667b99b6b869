//! Adam (Kingma & Ba) with bias correction, as the paper trains with.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Adam's moment estimates and step count.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Adam {
    /// First moments.
    pub m: Vec<f32>,
    /// Second moments.
    pub v: Vec<f32>,
    /// Updates applied.
    pub t: u64,
}

impl Adam {
    /// Zeroed state for `n` parameters.
    pub fn new(n: usize) -> Self {
        Self { m: vec![0.0; n], v: vec![0.0; n], t: 0 }
    }

    /// One update: `m ← β₁m + (1−β₁)g`, `v ← β₂v + (1−β₂)g²`,
    /// `p ← p − lr·m̂/(√v̂ + ε)` with `m̂ = m/(1−β₁ᵗ)`, `v̂ = v/(1−β₂ᵗ)`.
    pub fn update(&mut self, p: &mut [f32], g: &[f32], lr: f32, b1: f32, b2: f32, eps: f32) {
        self.t += 1;
        let bc1 = 1.0 - (b1 as f64).powi(self.t as i32) as f32;
        let bc2 = 1.0 - (b2 as f64).powi(self.t as i32) as f32;
        // element-wise: split in blocks across threads (a feature grid's
        // table makes millions of parameters)
        const BLOCK: usize = 1 << 16;
        let blocks = p.par_chunks_mut(BLOCK).zip(g.par_chunks(BLOCK)).zip(self.m.par_chunks_mut(BLOCK));
        blocks.zip(self.v.par_chunks_mut(BLOCK)).for_each(|(((p, g), m), v)| {
            for (((p, g), m), v) in p.iter_mut().zip(g).zip(m).zip(v) {
                *m = b1 * *m + (1.0 - b1) * g;
                *v = b2 * *v + (1.0 - b2) * g * g;
                *p -= lr * (*m / bc1) / ((*v / bc2).sqrt() + eps);
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
        let mut a = Adam::new(2);
        let mut p = [1.0f32, -2.0];
        for k in 1..=10 {
            a.update(&mut p, &[0.5, -4.0], 0.01, 0.9, 0.999, 1e-8);
            assert!((p[0] - (1.0 - 0.01 * k as f32)).abs() < 1e-5, "step {k}: {}", p[0]);
            assert!((p[1] - (-2.0 + 0.01 * k as f32)).abs() < 1e-5);
        }
        assert_eq!(a.t, 10);
    }

    #[test]
    fn minimises_a_quadratic() {
        let mut a = Adam::new(1);
        let mut p = [3.0f32];
        for _ in 0..2000 {
            let g = [2.0 * (p[0] - 1.5)];
            a.update(&mut p, &g, 0.01, 0.9, 0.999, 1e-8);
        }
        assert!((p[0] - 1.5).abs() < 1e-2);
    }
}
