//! Image quality metrics on RGB images in `[0, 1]`.

/// Mean squared error over all pixels and channels.
pub fn mse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let s: f64 = a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |c| ((x[c] - y[c]) as f64).powi(2))).sum();
    s / (3 * a.len().max(1)) as f64
}

/// Peak signal-to-noise ratio in dB for peak 1 (capped at 100 dB for identical images).
pub fn psnr(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let m = mse(a, b);
    if m <= 1e-10 {
        100.0
    } else {
        -10.0 * m.log10()
    }
}

/// Structural similarity (Wang et al. 2004) as the NeRF paper reports it:
/// 11×11 Gaussian window (σ = 1.5), `C₁ = 0.01²`, `C₂ = 0.03²`, valid
/// region only, averaged over channels. Images smaller than the window use
/// the largest window that fits.
pub fn ssim(a: &[[f32; 3]], b: &[[f32; 3]], width: usize, height: usize) -> f64 {
    let win = 11.min(width).min(height);
    let half = win / 2;
    let sigma = 1.5f64;
    let g: Vec<f64> = (0..win).map(|i| (-((i as f64 - half as f64).powi(2)) / (2.0 * sigma * sigma)).exp()).collect();
    let gs: f64 = g.iter().sum();
    let g: Vec<f64> = g.iter().map(|v| v / gs).collect();
    let (c1, c2) = (1e-4, 9e-4);
    let (ow, oh) = (width + 1 - win, height + 1 - win);
    let mut total = 0.0;
    for c in 0..3 {
        // separable filtering of x, y, x², y², xy
        let filt = |f: &dyn Fn(usize) -> f64| -> Vec<f64> {
            let mut tmp = vec![0.0; ow * height];
            for y in 0..height {
                for x in 0..ow {
                    tmp[y * ow + x] = (0..win).map(|k| g[k] * f(y * width + x + k)).sum();
                }
            }
            let mut out = vec![0.0; ow * oh];
            for y in 0..oh {
                for x in 0..ow {
                    out[y * ow + x] = (0..win).map(|k| g[k] * tmp[(y + k) * ow + x]).sum();
                }
            }
            out
        };
        let xa = |i: usize| a[i][c] as f64;
        let yb = |i: usize| b[i][c] as f64;
        let mx = filt(&xa);
        let my = filt(&yb);
        let sxx = filt(&|i| xa(i) * xa(i));
        let syy = filt(&|i| yb(i) * yb(i));
        let sxy = filt(&|i| xa(i) * yb(i));
        let mut s = 0.0;
        for i in 0..ow * oh {
            let (vx, vy, cxy) = (sxx[i] - mx[i] * mx[i], syy[i] - my[i] * my[i], sxy[i] - mx[i] * my[i]);
            s += ((2.0 * mx[i] * my[i] + c1) * (2.0 * cxy + c2))
                / ((mx[i].powi(2) + my[i].powi(2) + c1) * (vx + vy + c2));
        }
        total += s / (ow * oh) as f64;
    }
    total / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_score_perfectly() {
        let img: Vec<[f32; 3]> = (0..400).map(|i| [(i % 20) as f32 / 20.0, 0.5, (i / 20) as f32 / 20.0]).collect();
        assert_eq!(psnr(&img, &img), 100.0);
        assert!((ssim(&img, &img, 20, 20) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn known_values() {
        let a = vec![[0.5f32; 3]; 256];
        let b = vec![[0.6f32; 3]; 256];
        assert!((psnr(&a, &b) - 20.0).abs() < 1e-4);
        let noisy: Vec<[f32; 3]> = (0..256).map(|i| [if i % 2 == 0 { 0.4 } else { 0.6 }; 3]).collect();
        let s = ssim(&a, &noisy, 16, 16);
        assert!(s < 0.5 && s > 0.0, "{s}");
    }
}
