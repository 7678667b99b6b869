//! The interlevel loss of mip-NeRF 360 (Barron et al., 2022, eq. 13): a
//! proposal's weights must bound the network's along each ray.
//!
//! The network's sample `i` owns the interval `[tᵢ, tᵢ₊₁)` of its
//! samples `t` (the last one out to infinity), with weight `wᵢ`; the
//! proposal's sample `j` owns `[eⱼ, eⱼ₊₁)` of its edges `e` (`n + 1`
//! edges for `n` weights, the ends may be infinite), with weight `ŵⱼ`. The
//! bound of interval `i` is the sum of the proposal weights whose
//! intervals overlap it, `bᵢ = Σ ŵⱼ`, and the loss is
//! `L = Σᵢ max(0, wᵢ − bᵢ)² / (wᵢ + ε)`. The network's weights are
//! constants here (no gradient reaches the network); the gradient flows to
//! the proposal's weights only: `∂L/∂ŵⱼ = Σ_{i overlapping j} −2·max(0, wᵢ − bᵢ)/(wᵢ + ε)`.

/// ε of the loss's denominator (mip-NeRF 360's).
pub const EPS: f32 = 1e-7;

/// The interlevel loss of one ray (see the module doc): the network's
/// sorted samples `t` and weights `w` (as many), the proposal's sorted
/// `edges` and weights `w_p` (one more edge than weights). Adds
/// `scale · ∂L/∂ŵⱼ` to `dw_p` (as long as `w_p`) and returns `L`.
pub fn interlevel(t: &[f32], w: &[f32], edges: &[f32], w_p: &[f32], scale: f32, dw_p: &mut [f32]) -> f32 {
    let m = w_p.len();
    debug_assert!(w.len() == t.len() && edges.len() == m + 1 && dw_p.len() == m);
    // a difference array of the gradient
    let mut diff = vec![0.0f64; m + 1];
    let mut loss = 0.0f64;
    bounds(t, w, edges, w_p, |i, bound, lo, hi| {
        let excess = (w[i] - bound).max(0.0);
        if excess > 0.0 {
            let d = w[i] + EPS;
            loss += (excess * excess / d) as f64;
            let g = (-2.0 * excess / d * scale) as f64;
            diff[lo] += g;
            diff[hi] -= g;
        }
    });
    let mut run = 0.0f64;
    for (j, d) in dw_p.iter_mut().enumerate() {
        run += diff[j];
        *d += run as f32;
    }
    loss as f32
}

/// The network's weight along one ray that the proposal leaves unbounded,
/// `Σᵢ max(0, wᵢ − bᵢ)` (arguments as [`interlevel`]'s): 0 when the
/// proposal bounds every interval, at most `Σ wᵢ`.
pub fn unbounded_weight(t: &[f32], w: &[f32], edges: &[f32], w_p: &[f32]) -> f32 {
    let mut sum = 0.0f32;
    bounds(t, w, edges, w_p, |i, bound, _, _| sum += (w[i] - bound).max(0.0));
    sum
}

/// Calls `f(i, bᵢ, lo, hi)` for each of the network's intervals `i` that
/// proposal intervals `lo..hi` overlap (see the module doc).
fn bounds(t: &[f32], w: &[f32], edges: &[f32], w_p: &[f32], mut f: impl FnMut(usize, f32, usize, usize)) {
    let (n, m) = (t.len(), w_p.len());
    debug_assert!(w.len() == n && edges.len() == m + 1);
    let mut cum = Vec::with_capacity(m + 1);
    cum.push(0.0f64);
    for &v in w_p {
        cum.push(cum[cum.len() - 1] + v as f64);
    }
    let (mut lo, mut hi) = (0usize, 0usize);
    for i in 0..n {
        let (a, b) = (t[i], if i + 1 < n { t[i + 1] } else { f32::INFINITY });
        // proposal intervals j with e_j < b and e_{j+1} > a: lo..hi
        while lo < m && edges[lo + 1] <= a {
            lo += 1;
        }
        hi = hi.max(lo);
        while hi < m && edges[hi] < b {
            hi += 1;
        }
        if lo < hi {
            f(i, (cum[hi] - cum[lo]) as f32, lo, hi);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bounding_proposal_costs_nothing() {
        // the network's weight sits in [1, 2); the proposal puts 0.9 over [0.5, 2.5)
        let t = [0.0, 1.0, 2.0, 3.0];
        let w = [0.0, 0.8, 0.1, 0.0];
        let edges = [0.0, 0.5, 2.5, f32::INFINITY];
        let w_p = [0.05, 0.9, 0.05];
        let mut g = [0.0; 3];
        assert_eq!(interlevel(&t, &w, &edges, &w_p, 1.0, &mut g), 0.0);
        assert_eq!(g, [0.0; 3]);
        // a proposal elsewhere costs w²/w for each interval it leaves unbounded: [1, 2)'s 0.8 (the last
        // proposal interval, [2.5, ∞), bounds [2, 3)'s 0.1)
        let w_p = [0.9, 0.0, 0.1];
        let l = interlevel(&t, &w, &edges, &w_p, 1.0, &mut g);
        assert!((l - 0.8).abs() < 1e-5, "{l}");
        // raising the middle proposal weight lowers the loss
        assert!(g[1] < 0.0 && g[0] == 0.0, "{g:?}");
        assert!((unbounded_weight(&t, &w, &edges, &w_p) - 0.8).abs() < 1e-6);
        assert_eq!(unbounded_weight(&t, &w, &edges, &[0.05, 0.9, 0.05]), 0.0);
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let t = [0.1, 0.4, 0.45, 0.9, 1.7, 2.0];
        let w = [0.05, 0.3, 0.25, 0.2, 0.1, 0.02];
        let edges = [0.0, 0.2, 0.42, 0.5, 0.8, 1.0, 1.9, f32::INFINITY];
        let w_p = [0.02, 0.2, 0.1, 0.15, 0.05, 0.08, 0.01];
        let mut g = [0.0; 7];
        interlevel(&t, &w, &edges, &w_p, 1.0, &mut g);
        for j in 0..w_p.len() {
            let h = 1e-3;
            let at = |d: f32| {
                let mut p = w_p;
                p[j] += d;
                interlevel(&t, &w, &edges, &p, 1.0, &mut [0.0; 7]) as f64
            };
            let fd = (at(h) - at(-h)) / (2.0 * h as f64);
            assert!((fd - g[j] as f64).abs() < 2e-3 * (1.0 + fd.abs()), "w_p[{j}]: {} against {fd}", g[j]);
        }
        assert!(g.iter().any(|&v| v != 0.0));
    }
}
