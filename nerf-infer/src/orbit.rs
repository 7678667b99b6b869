//! The orbit a video follows around a model's scene: the circle fitted to
//! the training cameras when the model has one ([`FittedOrbit`]), otherwise
//! one chosen from its scene; [`Orbit::camera`] gives the camera at any
//! point of it.
//!
//! World axes are the model's: for the built-in scene and Blender captures
//! +z is up; for a fitted orbit, up is the orbit's `up` (the training
//! cameras' average up); a forward-facing (NDC) capture looks down −z with
//! +y up.

use crate::camera::{look_at_pose, Camera};
use crate::error::Result;
use crate::format::{FittedOrbit, Model, Scene};
use glam::Vec3;
use libm::{atan2f, atanf, cosf, hypotf, sinf};

/// The shape of an [`Orbit`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum OrbitKind {
    /// Around `centre` at `elevation` above the plane perpendicular to
    /// `up`, looking at it.
    Circle,
    /// Forward-facing scenes: the camera at `(radius·cos a, ½·radius·sin a,
    /// 0)` looking down −z.
    Spiral,
}

/// The path [`Orbit::camera`] follows around a scene.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Orbit {
    /// Circle or spiral.
    pub kind: OrbitKind,
    /// The point looked at, world units.
    pub centre: [f32; 3],
    /// The circle's axis and the cameras' up, a unit vector.
    pub up: [f32; 3],
    /// Distance from the centre (circle) or the spiral's radius, world units.
    pub radius: f32,
    /// Elevation above the plane through `centre` perpendicular to `up`, radians.
    pub elevation: f32,
    /// Azimuth of the first camera, radians (see [`FittedOrbit::azimuth`]).
    pub azimuth: f32,
    /// Horizontal field of view, radians.
    pub fov_x: f32,
}

impl Orbit {
    /// The orbit of `model` ([`Orbit::new`] with its scene and fitted orbit).
    pub fn of(model: &Model<'_>) -> Orbit {
        Orbit::new(&model.scene, model.orbit.as_ref())
    }

    /// The orbit of a model with scene `scene` and fitted orbit `fitted`:
    ///
    /// - forward-facing (NDC) scenes: a small circle in the image plane of
    ///   the capture's average pose, looking down −z with the capture's
    ///   field of view (LLFF's spiral without the depth motion);
    /// - with a fitted orbit: that circle (its centre, up, radius and
    ///   height, the training cameras' field of view);
    /// - otherwise up is +z (Blender's), and the circle at 30° elevation
    ///   around the bounds' centre at the middle of the near..far range
    ///   (unbounded scenes, whose bounds hold the cameras: at 0.45 of the
    ///   bounds' smaller horizontal extent), field of view 0.69 rad as
    ///   lego's.
    pub fn new(scene: &Scene, fitted: Option<&FittedOrbit>) -> Orbit {
        if let Some(n) = scene.ndc {
            // the capture is normalised so its nearest depth is 1/0.75: move by a tenth of it
            let fov_x = 2.0 * atanf(0.5 * n.width / n.focal);
            let (centre, up) = ([0.0; 3], [0.0, 1.0, 0.0]);
            return Orbit { kind: OrbitKind::Spiral, centre, up, radius: 0.1, elevation: 0.0, azimuth: 0.0, fov_x };
        }
        if let Some(f) = fitted {
            let (radius, elevation) = (hypotf(f.radius, f.height), atan2f(f.height, f.radius));
            let up = Vec3::from(f.up).normalize().to_array();
            let (centre, azimuth, fov_x) = (f.centre, f.azimuth, f.fov_x);
            return Orbit { kind: OrbitKind::Circle, centre, up, radius, elevation, azimuth, fov_x };
        }
        let lo = Vec3::from(scene.bounds_min);
        let hi = Vec3::from(scene.bounds_max);
        let radius = match scene.unbounded {
            Some(_) => 0.45 * (hi - lo).x.min((hi - lo).y),
            None => 0.5 * (scene.near + scene.far),
        };
        let centre = (0.5 * (lo + hi)).to_array();
        let (up, elevation) = ([0.0, 0.0, 1.0], 30f32.to_radians());
        Orbit { kind: OrbitKind::Circle, centre, up, radius, elevation, azimuth: 0.0, fov_x: 0.691_111_2 }
    }

    /// The camera `turn` of the way along the orbit (0 and 1: the first
    /// camera; any real number), `width × height` pixels with the orbit's
    /// field of view. Fails with [`crate::Error::InvalidCamera`] if `turn`
    /// or a field is not finite or the orbit degenerate (zero radius).
    pub fn camera(&self, turn: f32, width: u32, height: u32) -> Result<Camera> {
        let az = self.azimuth + turn * core::f32::consts::TAU;
        if self.kind == OrbitKind::Spiral {
            let r = self.radius;
            let m = [[1.0, 0.0, 0.0, r * cosf(az)], [0.0, 1.0, 0.0, 0.5 * r * sinf(az)], [0.0, 0.0, 1.0, 0.0]];
            return Camera::from_fov(width, height, self.fov_x, m);
        }
        let (centre, up, el) = (Vec3::from(self.centre), Vec3::from(self.up), self.elevation);
        let (u1, u2) = azimuth_axes(up);
        let (ce, se) = (cosf(el), sinf(el));
        let eye = centre + self.radius * (ce * cosf(az) * u1 + ce * sinf(az) * u2 + se * up);
        Camera::from_fov(width, height, self.fov_x, look_at_pose(eye, centre, up))
    }
}

/// The directions of azimuth 0 and 90° in the plane perpendicular to the
/// unit vector `up`: `u₁` is +x made perpendicular to it (+y when
/// |up·x| > 0.9), `u₂ = up × u₁` (for up = +z, +x and +y).
pub fn azimuth_axes(up: Vec3) -> (Vec3, Vec3) {
    let v = if up.x.abs() > 0.9 { Vec3::Y } else { Vec3::X };
    let u1 = (v - v.dot(up) * up).normalize();
    (u1, up.cross(u1))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every camera of the default circle is at its radius from the centre,
    /// looks at it, and keeps +z up in its image; a quarter turn moves it a
    /// quarter of the way round.
    #[test]
    fn circle_cameras_look_at_the_centre_with_z_up() {
        let scene = Scene::blender(1.5, 2.0, 6.0);
        let o = Orbit::new(&scene, None);
        for k in 0..8 {
            let cam = o.camera(k as f32 / 8.0, 16, 16).unwrap();
            let centre = Vec3::from(o.centre);
            assert!(((cam.position - centre).length() - 4.0).abs() < 1e-4);
            let (_, d) = cam.ray_at(8.0, 8.0);
            assert!(d.normalize().dot((centre - cam.position).normalize()) > 0.9999);
            // the image's up (camera +y) has a positive z; its right (+x) none
            assert!(cam.rotation.y_axis.z > 0.0 && cam.rotation.x_axis.z.abs() < 1e-6);
        }
        let (a, b) = (o.camera(0.0, 4, 4).unwrap().position, o.camera(0.25, 4, 4).unwrap().position);
        assert!((a.x * b.x + a.y * b.y).abs() < 1e-4, "{a} {b}");
        assert!(o.camera(f32::NAN, 4, 4).is_err());
        // a quarter turn from +x is +y, at 30° elevation, 0.5·(near + far) from the centre
        let c = o.camera(0.25, 8, 8).unwrap();
        let want = 4.0 * Vec3::new(0.0, cosf(30f32.to_radians()), sinf(30f32.to_radians()));
        assert!((c.position - want).length() < 1e-4, "{}", c.position);
    }

    #[test]
    fn the_azimuth_axes_are_orthonormal_for_every_up() {
        for up in [Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::X, Vec3::Y, Vec3::new(0.95, 0.1, 0.3).normalize()] {
            let (u1, u2) = azimuth_axes(up);
            for (a, b) in [(u1, u2), (u1, up), (u2, up)] {
                assert!(a.dot(b).abs() < 1e-6 && (a.length() - 1.0).abs() < 1e-6, "{up}");
            }
            assert!(u1.cross(u2).dot(up) > 0.999, "{up}: right-handed");
        }
        assert_eq!(azimuth_axes(Vec3::Z), (Vec3::X, Vec3::Y));
    }
}
