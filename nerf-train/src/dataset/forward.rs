//! Forward-facing captures (LLFF's, and COLMAP's or instant-ngp's that the
//! scene fit finds forward-facing): nerf-pytorch's normalisation of their
//! poses and the NDC scene they are rendered in.

use glam::{DMat3, DVec3};
use nerf_infer::camera::Camera;
use nerf_infer::format::{CameraConvention, Ndc, Scene};

/// NDC depth (z) of the nearest scene depth of a [`ForwardFrame`]: its
/// scale puts the nearest depth at 1/0.75 and the near plane at 1, and NDC
/// z is `1 − 2 / depth`.
const NEAREST_NDC_Z: f32 = -0.5;
/// Room left around the rays in x and y (a fraction of the extent): the
/// corners of a distorted photo and the downscale's crop.
const NDC_MARGIN: f32 = 1.05;

/// The NDC scene of a forward-facing capture whose first view is `v0`,
/// its box holding every ray of `cameras` (pinholes in the normalised
/// frame) from the nearest scene depth to infinity: `t ∈ [0, 1]`, black
/// background. NDC is built on the mean pose, so the rays of a camera away
/// from it leave `[−1, 1]` in x and y; a box of `[−1, 1]³` cut them (a
/// held-out photo's edge rendered the background). z spans `[−1, 1]`, x
/// and y the rays' extent with a margin ([`NDC_MARGIN`]), at least `[−1, 1]`.
pub(super) fn ndc_scene(v0: &Camera, cameras: &[Camera]) -> Scene {
    let ndc = Ndc { focal: v0.fx, width: v0.width as f32, height: v0.height as f32 };
    let mut half = glam::Vec2::ONE;
    for c in cameras {
        let (w, h) = (c.width as f32, c.height as f32);
        for (u, v) in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)] {
            let (o, d) = c.ray_at(u, v);
            let Some((o, d)) = nerf_infer::camera::ndc_ray(ndc.width, ndc.height, ndc.focal, 1.0, o, d) else {
                continue;
            };
            // the nearest depth's point, and the one at infinity (t = 1)
            let near = o + d * ((NEAREST_NDC_Z - o.z) / d.z);
            for p in [near, o + d] {
                if p.is_finite() {
                    half = half.max(glam::Vec2::new(p.x.abs(), p.y.abs()) * NDC_MARGIN);
                }
            }
        }
    }
    Scene {
        bounds_min: [-half.x, -half.y, -1.0],
        bounds_max: [half.x, half.y, 1.0],
        near: 0.0,
        far: 1.0,
        white_background: false,
        convention: CameraConvention::OpenGl,
        ndc: Some(ndc),
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
