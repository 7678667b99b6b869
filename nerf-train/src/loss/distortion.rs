//! The distortion loss of mip-NeRF 360 (Barron et al., 2022, eq. 15) and
//! its gradient, over a ray's samples in a normalised coordinate along it.

/// The distortion loss of one ray (mip-NeRF 360, eq. 15) and its
/// gradient: sample `i` stands for the interval of midpoint `mid[i]`
/// (ascending) and length `width[i]` in the ray's normalised coordinate
/// ([`ray_s`], in `[0, 1]`) and has weight `w[i]`;
/// `L = Σᵢⱼ wᵢwⱼ|midᵢ − midⱼ| + ⅓ Σᵢ wᵢ² widthᵢ`. `L` is small when the
/// weight gathers in a short stretch of the ray (a surface) and grows as
/// it spreads along it (fog, floaters). Writes `scale · ∂L/∂wᵢ` into `dw`
/// (O(n) with prefix sums) and returns `L`.
///
/// # Panics
/// If `mid`, `width` or `dw` holds fewer values than `w`.
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
    use crate::composite::tests::check_density_gradients;
    use crate::composite::{composite, composite_back, push_deltas};

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
}
