//! The density penalty's term: a ray's optical depth and its gradient
//! ([`LossConfig::density_l1`](crate::config::LossConfig::density_l1)).

use crate::composite::LAST_DELTA;

/// The optical depth of one ray, `Σᵢ max(σᵢ, 0)·δᵢ` (σ in 1/world units,
/// δ in world units, the sum unitless) over its samples but one whose δ
/// is [`LAST_DELTA`] (its density changes no render): the quantity
/// [`LossConfig::density_l1`](crate::config::LossConfig::density_l1) penalises.
pub fn optical_depth(sigma: &[f32], delta: &[f32]) -> f32 {
    sigma.iter().zip(delta).filter(|&(_, &d)| d < LAST_DELTA).map(|(&s, &d)| s.max(0.0) * d).sum()
}

/// Adds `scale · ∂/∂σᵢ` of [`optical_depth`] to `dsigma`: `scale·δᵢ`
/// where `σᵢ > 0` (and δᵢ is not [`LAST_DELTA`]), nothing elsewhere.
pub fn optical_depth_back(sigma: &[f32], delta: &[f32], scale: f32, dsigma: &mut [f32]) {
    for ((g, &s), &d) in dsigma.iter_mut().zip(sigma).zip(delta) {
        if s > 0.0 && d < LAST_DELTA {
            *g += scale * d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::composite::push_deltas;

    #[test]
    fn optical_depth_gradient_matches_finite_differences() {
        let sigma = [0.3f32, -0.8, 2.5, 0.0, 1.2, 4.0];
        let mut d = Vec::new();
        push_deltas(&[2.0, 2.3, 2.7, 3.0, 3.4, 3.9], 1.1, &mut d);
        // the last sample's σ is not counted, however large
        assert!((optical_depth(&sigma, &d) - 1.1 * (0.3 * 0.3 + 2.5 * 0.3 + 1.2 * 0.5)).abs() < 1e-5);
        let mut g = [0.5f32; 6];
        optical_depth_back(&sigma, &d, 2.0, &mut g);
        let h = 1e-3;
        for k in 0..6 {
            let (mut a, mut b) = (sigma, sigma);
            a[k] += h;
            b[k] -= h;
            let fd = 2.0 * (optical_depth(&a, &d) - optical_depth(&b, &d)) / (2.0 * h);
            // σ = 0 sits on the kink of max(σ, 0): the gradient is the right-hand 0
            let want = if sigma[k] == 0.0 { 0.0 } else { fd };
            assert!((g[k] - 0.5 - want).abs() < 1e-3, "σ{k}: {} vs {want}", g[k] - 0.5);
        }
    }
}
