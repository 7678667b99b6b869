//! The volume-rendering quadrature for training: forward with the same
//! formula as `nerf_infer::composite`, and its hand-written backward.
//!
//! For one ray with samples `i`: `sᵢ = max(σᵢ,0)·δᵢ`, `Tᵢ = exp(−Σⱼ<ᵢ sⱼ)`,
//! `wᵢ = Tᵢ − Tᵢ₊₁`, `C = bg + Σ wᵢ(cᵢ − bg)` for a background colour
//! `bg`, channel by channel. Then `∂C/∂cᵢ = wᵢ` and `∂C/∂sₖ = Tₖ₊₁(cₖ − bg) − Σᵢ>ₖ wᵢ(cᵢ − bg)`.

/// δ of the last sample (the paper's 1e10), also used by the f32 kernel.
pub const LAST_DELTA: f32 = 1e10;

/// Appends the δ of each sample of one ray to `out`: `δᵢ = (tᵢ₊₁ − tᵢ)·|d|`
/// (world units) for sorted `t` and `dir_len = |d|`, [`LAST_DELTA`] for the last.
pub fn push_deltas(t: &[f32], dir_len: f32, out: &mut Vec<f32>) {
    let n = t.len();
    out.extend((0..n).map(|i| if i + 1 < n { (t[i + 1] - t[i]) * dir_len } else { LAST_DELTA }));
}

/// Forward of one ray: writes each sample's weight into `w` and returns the
/// composited colour. `delta` holds each sample's δ in world units (see
/// [`push_deltas`]; samples skipped in empty space simply are not there).
///
/// # Panics
/// If `sigma` or `w` holds fewer values than `delta`, or `rgb` fewer than three per value of `delta`.
pub fn composite(sigma: &[f32], rgb: &[f32], delta: &[f32], bg: [f32; 3], w: &mut [f32]) -> [f32; 3] {
    let n = delta.len();
    let mut trans = 1.0f32;
    let mut c = [0.0f32; 3];
    let mut acc = 0.0f32;
    for i in 0..n {
        let alpha = nerf_infer::composite::alpha_f32(sigma[i], delta[i]);
        let wi = trans * alpha;
        trans *= 1.0 - alpha;
        w[i] = wi;
        acc += wi;
        for k in 0..3 {
            c[k] += wi * rgb[3 * i + k];
        }
    }
    std::array::from_fn(|k| c[k] + (1.0 - acc) * bg[k])
}

/// Backward of [`composite`]: given `dc` = ∂L/∂C, `dw` = ∂L/∂wᵢ of a loss
/// on the weights themselves (such as [`distortion`](crate::loss::distortion::distortion); empty: none) and the
/// forward weights `w`, writes ∂L/∂σᵢ into `dsigma` and ∂L/∂cᵢ into `drgb`.
/// (`∂wᵢ/∂sₖ` is `Tₖ₊₁` for `i = k` and `−wᵢ` for `i > k`, so a weight's
/// gradient flows as a colour's does.) A sample with `σᵢ ≤ 0` gets none
/// (the slope of `max(σ, 0)`), unless no sample of the ray has density:
/// then every sample gets the gradient at `σ = 0⁺`, so a field that early
/// steps left empty everywhere grows back instead of staying dark.
///
/// # Panics
/// If `sigma`, `w` or `dsigma` holds fewer values than `delta`, or `rgb` or `drgb` fewer than three per value of
/// `delta`.
#[allow(clippy::too_many_arguments)]
pub fn composite_back(
    sigma: &[f32],
    rgb: &[f32],
    delta: &[f32],
    bg: [f32; 3],
    w: &[f32],
    dc: [f32; 3],
    dw: &[f32],
    dsigma: &mut [f32],
    drgb: &mut [f32],
) {
    let n = delta.len();
    // suffix[k] = Σ_{i>k} wᵢ (cᵢ − bg)·dc, and T_{k+1} = 1 − Σ_{i≤k} wᵢ.
    let mut suffix = 0.0f32;
    let total: f32 = w.iter().sum();
    let empty = total == 0.0;
    let mut prefix = total; // Σ_{i≤k} w_i, walked backwards
    for k in (0..n).rev() {
        let ck: f32 = (0..3).map(|j| (rgb[3 * k + j] - bg[j]) * dc[j]).sum::<f32>() + dw.get(k).copied().unwrap_or(0.0);
        for j in 0..3 {
            drgb[3 * k + j] = w[k] * dc[j];
        }
        let t_next = (1.0 - prefix).max(0.0);
        let ds = t_next * ck - suffix;
        // σ of a sample with δ = LAST_DELTA has no effect (α = 1 already)
        dsigma[k] = if (sigma[k] > 0.0 || empty) && delta[k] < LAST_DELTA { ds * delta[k] } else { 0.0 };
        suffix += w[k] * ck;
        prefix -= w[k];
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn gradients_match_finite_differences_on_white_and_on_a_colour() {
        for bg in [[1.0f32; 3], [0.2, 0.9, 0.5]] {
            check_gradients(bg);
        }
    }

    fn check_gradients(bg: [f32; 3]) {
        let sigma = [0.0f32, 0.8, 2.5, -0.3, 1.2, 4.0];
        let rgb: Vec<f32> = (0..18).map(|i| ((i * 7) % 10) as f32 / 10.0).collect();
        let t = [2.0f32, 2.3, 2.7, 3.0, 3.4, 3.9];
        let mut d = Vec::new();
        push_deltas(&t, 1.3, &mut d);
        let dc = [0.7f32, -1.1, 0.4];
        let loss = |s: &[f32], c: &[f32]| {
            let mut w = [0.0; 6];
            let col = composite(s, c, &d, bg, &mut w);
            (0..3).map(|j| (col[j] * dc[j]) as f64).sum::<f64>()
        };
        let mut w = [0.0; 6];
        composite(&sigma, &rgb, &d, bg, &mut w);
        let (mut ds, mut dr) = ([0.0; 6], [0.0; 18]);
        composite_back(&sigma, &rgb, &d, bg, &w, dc, &[], &mut ds, &mut dr);
        check_density_gradients(&sigma, &ds, |s| loss(s, &rgb));
        let h = 1e-3;
        for k in 0..18 {
            let (mut a, mut b) = (rgb.clone(), rgb.clone());
            a[k] += h;
            b[k] -= h;
            let fd = (loss(&sigma, &a) - loss(&sigma, &b)) / (2.0 * h as f64);
            assert!((fd - dr[k] as f64).abs() < 2e-3, "c{k}: fd {fd} vs {}", dr[k]);
        }
    }

    #[test]
    fn an_empty_ray_pulls_its_densities_as_at_zero_plus() {
        let rgb: Vec<f32> = (0..18).map(|i| ((i * 7) % 10) as f32 / 10.0).collect();
        let mut d = Vec::new();
        push_deltas(&[2.0f32, 2.3, 2.7, 3.0, 3.4, 3.9], 1.1, &mut d);
        let (bg, dc) = ([0.0f32; 3], [-0.5f32, -0.8, 0.2]);
        let loss = |s: &[f32]| {
            let mut w = [0.0; 6];
            let col = composite(s, &rgb, &d, bg, &mut w);
            (0..3).map(|j| (col[j] * dc[j]) as f64).sum::<f64>()
        };
        let back = |sigma: &[f32; 6]| {
            let mut w = [0.0; 6];
            composite(sigma, &rgb, &d, bg, &mut w);
            let (mut ds, mut dr) = ([0.0; 6], [0.0; 18]);
            composite_back(sigma, &rgb, &d, bg, &w, dc, &[], &mut ds, &mut dr);
            ds
        };
        // no density anywhere: each sample's gradient is the one-sided difference at σ = 0⁺
        let empty = [-0.4f32, 0.0, -2.0, -0.1, 0.0, -1.0];
        let ds = back(&empty);
        let h = 1e-3;
        for k in 0..5 {
            let mut a = [0.0f32; 6];
            a[k] = h;
            let fd = (loss(&a) - loss(&[0.0; 6])) / h as f64;
            assert!(ds[k] != 0.0 && (fd - ds[k] as f64).abs() < 1e-4 + 1e-2 * fd.abs(), "σ{k}: fd {fd} vs {}", ds[k]);
        }
        // with density somewhere, the samples without it get none (max(σ, 0)'s gradient)
        let ds = back(&[-0.4f32, 0.0, 2.0, -0.1, 0.0, -1.0]);
        assert!(ds[0] == 0.0 && ds[1] == 0.0 && ds[3] == 0.0 && ds[2] != 0.0, "{ds:?}");
    }

    /// Central differences of `loss` against `ds` for every positive
    /// density but the last (whose δ is [`LAST_DELTA`]).
    pub(crate) fn check_density_gradients(sigma: &[f32; 6], ds: &[f32; 6], loss: impl Fn(&[f32]) -> f64) {
        let h = 1e-3;
        for k in 0..5 {
            if sigma[k] <= 0.0 {
                continue;
            }
            let (mut a, mut b) = (*sigma, *sigma);
            a[k] += h;
            b[k] -= h;
            let fd = (loss(&a) - loss(&b)) / (2.0 * h as f64);
            assert!((fd - ds[k] as f64).abs() < 2e-3, "σ{k}: fd {fd} vs {}", ds[k]);
        }
    }

    #[test]
    fn matches_the_kernel_compositor() {
        let sigma = [0.5f32, 3.0, 0.0, 7.0];
        let rgb = [0.1f32, 0.2, 0.3, 0.9, 0.8, 0.7, 0.5, 0.5, 0.5, 0.0, 1.0, 0.0];
        let t = [1.0f32, 1.5, 2.5, 3.0];
        let mut w = [0.0; 4];
        let mut d = Vec::new();
        push_deltas(&t, 1.0, &mut d);
        let c = composite(&sigma, &rgb, &d, [0.0; 3], &mut w);
        use nerf_infer::composite::{Compositor, CompositorF32};
        let mut k = CompositorF32::default();
        for i in 0..4 {
            let d = if i < 3 { t[i + 1] - t[i] } else { LAST_DELTA };
            k.add(sigma[i], d, [rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]], t[i]);
        }
        let p = k.finish(false, 3.0);
        for j in 0..3 {
            assert!((p.rgb[j] - c[j]).abs() < 1e-6);
        }
    }
}
