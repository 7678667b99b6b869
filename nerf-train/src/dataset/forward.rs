//! Forward-facing captures (LLFF's, and COLMAP's or instant-ngp's that the
//! scene fit finds forward-facing): nerf-pytorch's normalisation of their
//! poses and the NDC scene they are rendered in.

use glam::{DMat3, DVec3};
use nerf_infer::camera::Camera;
use nerf_infer::format::{CameraConvention, Ndc, Scene};

/// The NDC scene of a forward-facing capture whose first view is `v0`:
/// bounds `[−1, 1]³`, `t ∈ [0, 1]`, black background.
pub(super) fn ndc_scene(v0: &Camera) -> Scene {
    Scene {
        bounds_min: [-1.0; 3],
        bounds_max: [1.0; 3],
        near: 0.0,
        far: 1.0,
        white_background: false,
        convention: CameraConvention::OpenGl,
        ndc: Some(Ndc { focal: v0.fx, width: v0.width as f32, height: v0.height as f32 }),
        unbounded: None,
    }
}

/// nerf-pytorch's normalisation of a forward-facing capture: scale so the
/// nearest depth bound is 1/0.75, then recentre on the average pose.
pub(super) struct ForwardFrame {
    inv: DMat3,
    centre: DVec3,
    sc: f64,
}

impl ForwardFrame {
    /// The frame of `poses` (OpenGL axes: right, up, back; centres) whose
    /// nearest scene depth is `min_near` (capture units, > 0).
    pub(super) fn new(poses: &[(DMat3, DVec3)], min_near: f64) -> Self {
        let n = poses.len().max(1) as f64;
        let sc = 1.0 / (min_near * 0.75);
        // average pose: mean centre, z = mean back axis, y from mean up.
        let centre = poses.iter().map(|p| p.1 * sc).sum::<DVec3>() / n;
        let z = poses.iter().map(|p| p.0.z_axis).sum::<DVec3>().normalize();
        let up = poses.iter().map(|p| p.0.y_axis).sum::<DVec3>();
        let x = up.cross(z).normalize();
        let y = z.cross(x);
        Self { inv: DMat3::from_cols(x, y, z).transpose(), centre, sc }
    }

    /// `pose` in the normalised frame, row-major 3×4 camera-to-world.
    pub(super) fn apply(&self, pose: &(DMat3, DVec3)) -> [[f32; 4]; 3] {
        super::fit::pose_rows(&(self.inv * pose.0, self.inv * (pose.1 * self.sc - self.centre)))
    }
}
