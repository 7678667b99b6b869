//! Per-photo appearance: an affine colour correction per training photo,
//! `y = A·c + b` on the composited pixel colour `c` (a 3×3 matrix `A` and
//! an offset `b`, 12 values per photo), fitted beside the model so that
//! the field need not explain a photo's exposure or white balance with
//! geometry. The exported model renders the field's own colour, which
//! [`Appearance::recentre`] keeps at the photos' mean appearance (the
//! mean correction is the identity), and held-out photos are scored with it
//! ([`PerPhotoConfig::appearance`](crate::config::PerPhotoConfig::appearance)).

use super::PerPhoto;

/// Values per photo: `A` row by row, then `b`.
pub const PER_PHOTO: usize = 12;

/// The identity correction (`A = I`, `b = 0`).
pub const IDENTITY: [f32; PER_PHOTO] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];

/// Weight μ of the prior `μ · Σ_photo ‖p − identity‖²` added to the
/// colour loss. A photo's correction has few pixels behind it each step
/// and Adam moves it as far on a weak gradient as on a strong one: with a
/// much weaker prior the corrections wander and the field's colour with
/// them, away from every photo's, and a much stronger one holds them at
/// the identity. After each step
/// the corrections are also moved together so that their mean is the
/// identity ([`Appearance::recentre`]): scaling the field's colour up and
/// every photo's `A` down would cost the colour loss nothing.
pub const PRIOR: f32 = 1e-3;

/// The corrections' learning rate as a share of the network's
/// ([`OptimiserConfig::lr`](crate::config::OptimiserConfig::lr)), following its
/// decay.
pub const LR_SHARE: f32 = 0.1;

/// Each training photo's correction ([`PER_PHOTO`] values: `A` row by
/// row, then `b`) and their optimiser state.
pub type Appearance = PerPhoto<PER_PHOTO>;

impl Appearance {
    /// The identity correction for each of `photos` photos.
    pub fn new(photos: usize) -> Self {
        Self::filled(photos, IDENTITY)
    }

    /// Photo `photo`'s correction.
    pub fn of(&self, photo: usize) -> &[f32] {
        self.row(photo)
    }

    /// One Adam step at learning rate `optimiser.lr` on the colour loss's gradient
    /// `grad` (as `params`) plus [`PRIOR`]'s.
    pub fn update(&mut self, grad: &mut [f32], lr: f32, beta1: f32, beta2: f32, eps: f32) {
        for (i, g) in grad.iter_mut().enumerate() {
            *g += 2.0 * PRIOR * (self.params[i] - IDENTITY[i % PER_PHOTO]);
        }
        self.adam_step(grad, lr, beta1, beta2, eps);
        self.recentre();
    }

    /// Moves every correction by the same amount so that their mean is
    /// the identity: the field's own colour, which the model renders,
    /// stays the photos' mean appearance.
    pub fn recentre(&mut self) {
        recentre_rows(&mut self.params, &IDENTITY);
    }
}

/// Moves every row of `params` (rows of `target.len()` values, one per
/// photo) by the same amount so that their mean is `target` (the mean
/// taken in f64); nothing moves with an empty `target`.
pub fn recentre_rows(params: &mut [f32], target: &[f32]) {
    let per = target.len();
    let n = params.len().checked_div(per).unwrap_or(0);
    if n == 0 {
        return;
    }
    let mut mean = vec![0.0f64; per];
    for p in params.chunks_exact(per) {
        mean.iter_mut().zip(p).for_each(|(m, &v)| *m += v as f64 / n as f64);
    }
    for p in params.chunks_exact_mut(per) {
        for (i, v) in p.iter_mut().enumerate() {
            *v -= (mean[i] - target[i] as f64) as f32;
        }
    }
}

/// The corrected colour `A·c + b` of `c` under correction `p` ([`PER_PHOTO`] values).
pub fn apply(p: &[f32], c: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|r| p[3 * r] * c[0] + p[3 * r + 1] * c[1] + p[3 * r + 2] * c[2] + p[9 + r])
}

/// The backward pass of [`apply`]: adds `∂L/∂p` to `dp` for the gradient
/// `dy` of the loss with respect to the corrected colour, and returns the
/// gradient with respect to `c` (`Aᵀ·dy`).
pub fn apply_back(p: &[f32], c: [f32; 3], dy: [f32; 3], dp: &mut [f32]) -> [f32; 3] {
    for r in 0..3 {
        for k in 0..3 {
            dp[3 * r + k] += dy[r] * c[k];
        }
        dp[9 + r] += dy[r];
    }
    std::array::from_fn(|k| (0..3).map(|r| p[3 * r + k] * dy[r]).sum())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn loss(p: &[f32], c: [f32; 3], gt: [f32; 3]) -> f64 {
        apply(p, c).iter().zip(gt).map(|(&y, g)| ((y - g) as f64).powi(2)).sum()
    }

    #[test]
    fn rows_recentred_on_an_empty_target_stay_as_they_are() {
        let mut p = [0.5, 2.0, -1.0];
        recentre_rows(&mut p, &[]);
        assert_eq!(p, [0.5, 2.0, -1.0]);
    }

    #[test]
    fn apply_back_matches_finite_differences() {
        let p: Vec<f32> = (0..PER_PHOTO).map(|i| IDENTITY[i] + 0.07 * (i as f32 - 5.5).sin()).collect();
        let (c, gt) = ([0.2, 0.7, 0.4], [0.3, 0.5, 0.6]);
        let dy: [f32; 3] = std::array::from_fn(|r| 2.0 * (apply(&p, c)[r] - gt[r]));
        let mut dp = vec![0.0; PER_PHOTO];
        let dc = apply_back(&p, c, dy, &mut dp);
        let h = 1e-3;
        for i in 0..PER_PHOTO {
            let (mut a, mut b) = (p.clone(), p.clone());
            a[i] += h;
            b[i] -= h;
            let fd = (loss(&a, c, gt) - loss(&b, c, gt)) / (2.0 * h as f64);
            assert!((fd - dp[i] as f64).abs() < 1e-4, "p[{i}]: {fd} against {}", dp[i]);
        }
        for k in 0..3 {
            let (mut a, mut b) = (c, c);
            a[k] += h;
            b[k] -= h;
            let fd = (loss(&p, a, gt) - loss(&p, b, gt)) / (2.0 * h as f64);
            assert!((fd - dc[k] as f64).abs() < 1e-4, "c[{k}]: {fd} against {}", dc[k]);
        }
    }

    #[test]
    fn photos_darker_and_warmer_are_fitted() {
        // colours seen through two photos' exposures and white balances
        // whose mean is the identity: the corrections recover both mappings
        // from the colours alone
        let warm = [0.6, 0.0, 0.0, 0.05, 0.5, 0.0, 0.0, 0.0, 0.4, 0.05, 0.02, 0.0];
        let truth = [warm, std::array::from_fn(|i| 2.0 * IDENTITY[i] - warm[i])];
        let colours: Vec<[f32; 3]> =
            (0..64).map(|i| [(i % 4) as f32 / 3.0, (i / 4 % 4) as f32 / 3.0, (i / 16) as f32 / 3.0]).collect();
        let mut app = Appearance::new(2);
        for _ in 0..3000 {
            let mut grad = vec![0.0; app.params.len()];
            for (k, t) in truth.iter().enumerate() {
                let p = app.of(k).to_vec();
                for &c in &colours {
                    let gt = apply(t, c);
                    let dy: [f32; 3] = std::array::from_fn(|r| 2.0 * (apply(&p, c)[r] - gt[r]) / colours.len() as f32);
                    apply_back(&p, c, dy, &mut grad[k * PER_PHOTO..(k + 1) * PER_PHOTO]);
                }
            }
            app.update(&mut grad, 1e-2, 0.9, 0.99, 1e-15);
        }
        for (k, t) in truth.iter().enumerate() {
            for (i, (&got, &want)) in app.of(k).iter().zip(t).enumerate() {
                assert!((got - want).abs() < 0.01, "photo {k} value {i}: {got} against {want}");
            }
        }
    }

    #[test]
    fn recentring_keeps_the_differences_and_makes_the_mean_the_identity() {
        let mut app = Appearance::new(3);
        app.params.iter_mut().enumerate().for_each(|(i, v)| *v += 0.01 * i as f32);
        let before = app.params.clone();
        app.recentre();
        for i in 0..PER_PHOTO {
            let mean = (0..3).map(|k| app.of(k)[i]).sum::<f32>() / 3.0;
            assert!((mean - IDENTITY[i]).abs() < 1e-6, "value {i}: mean {mean}");
            let d = |p: &[f32]| p[PER_PHOTO + i] - p[i];
            assert!((d(&app.params) - d(&before)).abs() < 1e-6);
        }
    }
}
