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
/// on the weights themselves (such as [`distortion`]; empty: none) and the
/// forward weights `w`, writes ∂L/∂σᵢ into `dsigma` and ∂L/∂cᵢ into `drgb`.
/// (`∂wᵢ/∂sₖ` is `Tₖ₊₁` for `i = k` and `−wᵢ` for `i > k`, so a weight's
/// gradient flows as a colour's does.) A sample with `σᵢ ≤ 0` gets none
/// (the slope of `max(σ, 0)`), unless no sample of the ray has density:
/// then every sample gets the gradient at `σ = 0⁺`, so a field that early
/// steps left empty everywhere grows back instead of staying dark.
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

/// The distortion loss of one ray (mip-NeRF 360, eq. 15) and its
/// gradient: sample `i` stands for the interval of midpoint `mid[i]`
/// (ascending) and length `width[i]` in the ray's normalised coordinate
/// ([`ray_s`], in `[0, 1]`) and has weight `w[i]`;
/// `L = Σᵢⱼ wᵢwⱼ|midᵢ − midⱼ| + ⅓ Σᵢ wᵢ² widthᵢ`. `L` is small when the
/// weight gathers in a short stretch of the ray (a surface) and grows as
/// it spreads along it (fog, floaters). Writes `scale · ∂L/∂wᵢ` into `dw`
/// (O(n) with prefix sums) and returns `L`.
pub fn distortion(mid: &[f32], width: &[f32], w: &[f32], scale: f32, dw: &mut [f32]) -> f32 {
    let (w_all, wm_all): (f32, f32) = w.iter().zip(mid).fold((0.0, 0.0), |(a, b), (&wi, &mi)| (a + wi, b + wi * mi));
    let (mut w_before, mut wm_before) = (0.0f32, 0.0f32);
    let mut loss = 0.0f32;
    for i in 0..w.len() {
        let (wi, mi) = (w[i], mid[i]);
        let w_after = w_all - w_before - wi;
        let wm_after = wm_all - wm_before - wi * mi;
        // Σⱼ wⱼ|mᵢ − mⱼ| with the midpoints sorted
        let spread = (mi * w_before - wm_before) + (wm_after - mi * w_after);
        loss += wi * spread + wi * wi * width[i] / 3.0;
        dw[i] = scale * (2.0 * spread + 2.0 / 3.0 * wi * width[i]);
        w_before += wi;
        wm_before += wi * mi;
    }
    loss
}

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

/// The normalised coordinate `s ∈ [0, 1]` of the ray parameter `t`: even in
/// `t` over the ray's `near..far`, or in an unbounded scene the spacing
/// [`nerf_infer::unbounded::s_of_t`] gives (even in `t`, then in `1/t`).
pub fn ray_s(ray: &nerf_infer::camera::Ray, t: f32) -> f32 {
    match ray.linear_until {
        Some(lin) => nerf_infer::unbounded::s_of_t(t, lin),
        None => ((t - ray.near) / (ray.far - ray.near)).clamp(0.0, 1.0),
    }
}

/// Appends the interval of sample `j` of the sorted `t` (from `tⱼ` to
/// `tⱼ₊₁`, the last to the ray's far end) in [`ray_s`] coordinates to
/// `mid` and `width`, for [`distortion`].
pub fn push_interval(ray: &nerf_infer::camera::Ray, t: &[f32], j: usize, mid: &mut Vec<f32>, width: &mut Vec<f32>) {
    let a = ray_s(ray, t[j]);
    let b = ray_s(ray, t.get(j + 1).copied().unwrap_or(ray.far)).max(a);
    mid.push(0.5 * (a + b));
    width.push(b - a);
}

#[cfg(test)]
mod tests {
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

    /// `L` of [`distortion`] summed pair by pair.
    fn distortion_direct(mid: &[f32], width: &[f32], w: &[f32]) -> f64 {
        let n = w.len();
        let pairs: f64 = (0..n)
            .flat_map(|i| (0..n).map(move |j| (i, j)))
            .map(|(i, j)| (w[i] * w[j] * (mid[i] - mid[j]).abs()) as f64)
            .sum();
        pairs + (0..n).map(|i| (w[i] * w[i] * width[i]) as f64 / 3.0).sum::<f64>()
    }

    #[test]
    fn distortion_matches_its_pairwise_sum_and_finite_differences() {
        let mid = [0.05f32, 0.2, 0.21, 0.5, 0.7, 0.95];
        let width = [0.1f32, 0.15, 0.02, 0.3, 0.1, 0.1];
        let w = [0.1f32, 0.0, 0.4, 0.2, 0.05, 0.25];
        let mut dw = [0.0; 6];
        let l = distortion(&mid, &width, &w, 0.5, &mut dw);
        assert!((l as f64 - distortion_direct(&mid, &width, &w)).abs() < 1e-6, "{l}");
        let h = 1e-3;
        for k in 0..6 {
            let (mut a, mut b) = (w, w);
            a[k] += h;
            b[k] -= h;
            let fd =
                0.5 * (distortion_direct(&mid, &width, &a) - distortion_direct(&mid, &width, &b)) / (2.0 * h as f64);
            assert!((fd - dw[k] as f64).abs() < 1e-4, "w{k}: fd {fd} vs {}", dw[k]);
        }
        // the same weight on one short interval costs less than spread along the ray
        let mut scratch = [0.0; 6];
        let gathered = distortion(&mid, &width, &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0], 1.0, &mut scratch);
        let spread = distortion(&mid, &width, &[0.2, 0.0, 0.2, 0.2, 0.2, 0.2], 1.0, &mut scratch);
        assert!(gathered < 0.01 && spread > 0.2, "{gathered} {spread}");
    }

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

    #[test]
    fn a_weight_loss_flows_to_the_densities_as_finite_differences_say() {
        let sigma = [0.3f32, 0.8, 2.5, -0.3, 1.2, 4.0];
        let rgb: Vec<f32> = (0..18).map(|i| ((i * 3) % 10) as f32 / 10.0).collect();
        let t = [2.0f32, 2.3, 2.7, 3.0, 3.4, 3.9];
        let mut d = Vec::new();
        push_deltas(&t, 1.1, &mut d);
        let (mid, width): (Vec<f32>, Vec<f32>) = (0..6).map(|i| (i as f32 / 6.0 + 0.05, 0.1)).unzip();
        let (bg, dc, lambda) = ([0.3f32, 0.6, 0.1], [0.5f32, -0.8, 0.2], 0.7f32);
        let loss = |s: &[f32]| {
            let mut w = [0.0; 6];
            let col = composite(s, &rgb, &d, bg, &mut w);
            let dist = distortion_direct(&mid, &width, &w);
            (0..3).map(|j| (col[j] * dc[j]) as f64).sum::<f64>() + lambda as f64 * dist
        };
        let mut w = [0.0; 6];
        composite(&sigma, &rgb, &d, bg, &mut w);
        let mut dw = [0.0; 6];
        distortion(&mid, &width, &w, lambda, &mut dw);
        let (mut ds, mut dr) = ([0.0; 6], [0.0; 18]);
        composite_back(&sigma, &rgb, &d, bg, &w, dc, &dw, &mut ds, &mut dr);
        check_density_gradients(&sigma, &ds, loss);
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
    fn check_density_gradients(sigma: &[f32; 6], ds: &[f32; 6], loss: impl Fn(&[f32]) -> f64) {
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
    fn ray_coordinates_span_the_ray_evenly_or_as_the_unbounded_spacing() {
        let scene = nerf_infer::format::Scene {
            bounds_min: [-1.0; 3],
            bounds_max: [1.0; 3],
            near: 0.1,
            far: 10.0,
            white_background: false,
            convention: nerf_infer::format::CameraConvention::OpenGl,
            ndc: None,
            unbounded: None,
        };
        let ray = nerf_infer::camera::Ray::new(&scene, glam::Vec3::new(0.0, 0.0, 4.0), glam::Vec3::NEG_Z).unwrap();
        // the box from t = 3 to 5
        assert!((ray_s(&ray, 4.0) - 0.5).abs() < 1e-6 && ray_s(&ray, 3.0).abs() < 1e-6);
        let (mut mid, mut width) = (Vec::new(), Vec::new());
        push_interval(&ray, &[3.0, 4.0, 4.5], 2, &mut mid, &mut width);
        assert!((mid[0] - 0.875).abs() < 1e-6 && (width[0] - 0.25).abs() < 1e-6);
        let far =
            nerf_infer::format::Scene { unbounded: Some(nerf_infer::format::Unbounded { linear_until: 2.0 }), ..scene };
        let ray = nerf_infer::camera::Ray::new(&far, glam::Vec3::new(0.0, 0.0, 4.0), glam::Vec3::NEG_Z).unwrap();
        assert!((ray_s(&ray, 1.0) - 0.25).abs() < 1e-6 && (ray_s(&ray, 8.0) - 0.875).abs() < 1e-6);
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
