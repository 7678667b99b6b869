//! Camera pose refinement: a small rotation and translation per training
//! photo, fitted beside the model at
//! [`PerPhotoConfig::pose_lr`](crate::config::PerPhotoConfig::pose_lr), for captures whose poses (COLMAP's, a
//! phone's tracking) are a little off. Photo `k`'s camera is turned by the
//! rotation vector `ω` (radians, about its own centre) and moved by `δ`
//! (world units): a ray `(o, d)` of the photo becomes `(o + δ, R(ω)·d)`.
//! The rays' gradient reaches the corrections through the sample
//! positions and view directions ([`crate::mlp::Mlp::position_gradient`],
//! [`crate::mlp::Mlp::direction_gradient`]). After each step the shifts
//! are moved together so that their mean is zero ([`Poses::recentre`]):
//! moving every camera and the field with them would cost the colour loss
//! nothing. Three parts of a ray's dependence on its pose are left out of
//! the gradient: where its samples lie along it (the proposal grid's or
//! the occupancy grid's placement, the bounds' near and far), held as
//! nerfacto holds its proposal samples; the turn of a pixel footprint's
//! points about the ray with the view direction; and the turn's own
//! curvature (the gradient of `ω` is exact at `ω = 0`, [`ray_back`]).
//! The held-out photos keep the poses they were loaded with
//! ([`PerPhotoConfig::pose_refine`](crate::config::PerPhotoConfig::pose_refine)).

use super::PerPhoto;
use glam::Vec3;

/// Values per photo: `ω` (x, y, z, radians), then `δ` (x, y, z, world units).
pub const PER_PHOTO: usize = 6;

/// Each training photo's pose correction ([`PER_PHOTO`] values: `ω`,
/// then `δ`) and their optimiser state.
pub type Poses = PerPhoto<PER_PHOTO>;

impl Poses {
    /// No correction for each of `photos` photos.
    pub fn new(photos: usize) -> Self {
        Self::filled(photos, [0.0; PER_PHOTO])
    }

    /// Photo `photo`'s rotation vector `ω` (radians) and translation `δ` (world units).
    pub fn of(&self, photo: usize) -> (Vec3, Vec3) {
        let p = self.row(photo);
        (Vec3::new(p[0], p[1], p[2]), Vec3::new(p[3], p[4], p[5]))
    }

    /// The world-space ray `(origin, dir)` of photo `photo` as its
    /// correction places it: `(origin + δ, R(ω)·dir)`.
    pub fn apply(&self, photo: usize, origin: Vec3, dir: Vec3) -> (Vec3, Vec3) {
        let (w, t) = self.of(photo);
        (origin + t, rotate(w, dir))
    }

    /// One Adam step at learning rate `lr` on `grad` (as `params`), then
    /// [`Poses::recentre`].
    pub fn update(&mut self, grad: &mut [f32], lr: f32, beta1: f32, beta2: f32, eps: f32) {
        self.adam_step(grad, lr, beta1, beta2, eps);
        self.recentre();
    }

    /// Moves every photo's shift by the same amount so that their mean is
    /// zero: moving every camera and the field with them costs the colour
    /// loss nothing. The turns are left alone: turning every camera by the
    /// same amount about its own centre is not a motion of the whole scene
    /// (that would also move their centres), so the mean turn is not free.
    pub fn recentre(&mut self) {
        let n = self.photos();
        if n == 0 {
            return;
        }
        let mut mean = [0.0f64; 3];
        for p in self.params.chunks_exact(PER_PHOTO) {
            mean.iter_mut().zip(&p[3..]).for_each(|(m, &v)| *m += v as f64 / n as f64);
        }
        for p in self.params.chunks_exact_mut(PER_PHOTO) {
            p[3..].iter_mut().zip(&mean).for_each(|(v, m)| *v -= *m as f32);
        }
    }
}

/// `d` turned by the rotation vector `w` (radians; Rodrigues' formula).
pub fn rotate(w: Vec3, d: Vec3) -> Vec3 {
    let angle = w.length();
    if angle < 1e-12 {
        return d + w.cross(d);
    }
    let k = w / angle;
    let (s, c) = angle.sin_cos();
    d * c + k.cross(d) * s + k * k.dot(d) * (1.0 - c)
}

/// Adds to `dp` (one photo's [`PER_PHOTO`] values) the gradient of its
/// correction from the gradient of the loss with respect to a corrected
/// ray's world-space origin (`g_origin`) and direction (`g_dir`), `dir`
/// being the corrected direction: `δ` takes `g_origin`, `ω` takes `dir ×
/// g_dir` (the gradient of a further turn `R(ε)·R(ω)` at `ε = 0`, which is
/// `ω`'s own at `ω = 0`).
pub fn ray_back(dir: Vec3, g_origin: Vec3, g_dir: Vec3, dp: &mut [f32]) {
    let gw = dir.cross(g_dir);
    for (a, v) in dp[..3].iter_mut().zip(gw.to_array()) {
        *a += v;
    }
    for (a, v) in dp[3..6].iter_mut().zip(g_origin.to_array()) {
        *a += v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_keeps_length_and_turns_by_the_angle() {
        let w = Vec3::new(0.1, -0.2, 0.3);
        let d = Vec3::new(0.3, 0.5, -1.0);
        let r = rotate(w, d);
        assert!((r.length() - d.length()).abs() < 1e-6);
        // about the axis itself nothing turns; a quarter turn about z maps x to y
        assert!((rotate(w, w) - w).length() < 1e-7);
        let q = rotate(Vec3::Z * std::f32::consts::FRAC_PI_2, Vec3::X);
        assert!((q - Vec3::Y).length() < 1e-6, "{q}");
    }

    #[test]
    fn ray_back_matches_finite_differences_at_no_correction() {
        // L = a·o' + b·d' for the corrected ray of (o, d)
        let (o, d) = (Vec3::new(0.2, -0.4, 1.0), Vec3::new(0.3, 0.5, -1.0));
        let (a, b) = (Vec3::new(0.7, -0.1, 0.2), Vec3::new(-0.3, 0.9, 0.4));
        let loss = |p: &Poses| {
            let (o2, d2) = p.apply(0, o, d);
            (a.dot(o2) + b.dot(d2)) as f64
        };
        let poses = Poses::new(1);
        let mut dp = [0.0f32; PER_PHOTO];
        ray_back(d, a, b, &mut dp);
        let h = 1e-3;
        for i in 0..PER_PHOTO {
            let (mut p, mut m) = (poses.clone(), poses.clone());
            p.params[i] += h;
            m.params[i] -= h;
            let fd = (loss(&p) - loss(&m)) / (2.0 * h as f64);
            assert!((fd - dp[i] as f64).abs() < 1e-3, "value {i}: {fd} against {}", dp[i]);
        }
    }

    #[test]
    fn recentring_makes_the_mean_shift_zero_and_keeps_the_turns() {
        let mut poses = Poses::new(3);
        poses.params.iter_mut().enumerate().for_each(|(i, v)| *v = 0.01 * i as f32);
        let before = poses.params.clone();
        poses.recentre();
        for i in 0..PER_PHOTO {
            let mean = (0..3).map(|k| poses.params[k * PER_PHOTO + i]).sum::<f32>() / 3.0;
            if i < 3 {
                assert_eq!(
                    (0..3).map(|k| poses.params[k * PER_PHOTO + i]).collect::<Vec<_>>(),
                    [0.0, 0.06, 0.12].map(|v| v + 0.01 * i as f32)
                );
                continue;
            }
            assert!(mean.abs() < 1e-6, "value {i}: mean {mean}");
            let d = |p: &[f32]| p[PER_PHOTO + i] - p[i];
            assert!((d(&poses.params) - d(&before)).abs() < 1e-6);
        }
    }
}
