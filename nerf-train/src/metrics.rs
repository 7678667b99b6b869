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

/// [`psnr`] over the pixels `keep` marks (all of them where `keep` is
/// empty): the score of a photo whose mask leaves some pixels out.
pub fn psnr_kept(a: &[[f32; 3]], b: &[[f32; 3]], keep: &[bool]) -> f64 {
    if keep.is_empty() {
        return psnr(a, b);
    }
    let kept =
        |img: &[[f32; 3]]| -> Vec<[f32; 3]> { img.iter().zip(keep).filter(|(_, &k)| k).map(|(p, _)| *p).collect() };
    psnr(&kept(a), &kept(b))
}

/// Structural similarity (Wang et al. 2004) as the NeRF paper reports it:
/// 11×11 Gaussian window (σ = 1.5), `C₁ = 0.01²`, `C₂ = 0.03²`, valid
/// region only, averaged over channels. Images smaller than the window use
/// the largest window that fits.
///
/// # Panics
/// If `a` or `b` holds fewer than `width × height` pixels.
pub fn ssim(a: &[[f32; 3]], b: &[[f32; 3]], width: usize, height: usize) -> f64 {
    ssim_kept(a, b, width, height, &[])
}

/// [`ssim`] averaged over the windows whose centre pixel `keep` marks (all
/// windows where `keep` is empty; 1 where it marks none of them): the score
/// of a photo whose mask leaves some pixels out.
///
/// # Panics
/// If `a` or `b` holds fewer than `width × height` pixels, or `keep` is not empty and holds fewer.
pub fn ssim_kept(a: &[[f32; 3]], b: &[[f32; 3]], width: usize, height: usize, keep: &[bool]) -> f64 {
    let win = 11.min(width).min(height);
    let half = win / 2;
    let sigma = 1.5f64;
    let g: Vec<f64> = (0..win).map(|i| (-((i as f64 - half as f64).powi(2)) / (2.0 * sigma * sigma)).exp()).collect();
    let gs: f64 = g.iter().sum();
    let g: Vec<f64> = g.iter().map(|v| v / gs).collect();
    let (c1, c2) = (1e-4, 9e-4);
    let (ow, oh) = (width + 1 - win, height + 1 - win);
    // the windows scored: those centred on a kept pixel
    let scored: Vec<bool> =
        (0..ow * oh).map(|i| keep.is_empty() || keep[(i / ow + half) * width + i % ow + half]).collect();
    let count = scored.iter().filter(|&&k| k).count();
    if count == 0 {
        return 1.0;
    }
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
        for i in (0..ow * oh).filter(|&i| scored[i]) {
            let (vx, vy, cxy) = (sxx[i] - mx[i] * mx[i], syy[i] - my[i] * my[i], sxy[i] - mx[i] * my[i]);
            s += ((2.0 * mx[i] * my[i] + c1) * (2.0 * cxy + c2))
                / ((mx[i].powi(2) + my[i].powi(2) + c1) * (vx + vy + c2));
        }
        total += s / count as f64;
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

    #[test]
    fn scores_of_kept_pixels_ignore_the_rest() {
        let (w, h) = (24usize, 24usize);
        let a: Vec<[f32; 3]> =
            (0..w * h).map(|i| [(i % w) as f32 / w as f32, 0.5, (i / w) as f32 / h as f32]).collect();
        // b: a with its left half replaced by noise, and 0.1 added to the right half
        let b: Vec<[f32; 3]> = a
            .iter()
            .enumerate()
            .map(|(i, p)| if i % w < w / 2 { [((i * 7919) % 13) as f32 / 13.0; 3] } else { p.map(|c| c + 0.1) })
            .collect();
        let keep: Vec<bool> = (0..w * h).map(|i| i % w >= w / 2).collect();
        assert!((psnr_kept(&a, &b, &keep) - 20.0).abs() < 1e-3, "{}", psnr_kept(&a, &b, &keep));
        assert!(psnr(&a, &b) < 15.0);
        assert_eq!(psnr_kept(&a, &b, &[]), psnr(&a, &b));
        assert_eq!(ssim_kept(&a, &b, w, h, &[]), ssim(&a, &b, w, h));
        // windows centred in the right half but reaching 5 pixels left still see some noise; the kept
        // score is far above the whole image's
        let (all, kept) = (ssim(&a, &b, w, h), ssim_kept(&a, &b, w, h, &keep));
        assert!(kept > all + 0.2 && kept < 1.0, "{all} {kept}");
        let none = vec![false; w * h];
        assert_eq!(ssim_kept(&a, &b, w, h, &none), 1.0);
    }
}
