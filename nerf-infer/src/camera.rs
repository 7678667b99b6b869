//! Pinhole cameras and rays (OpenGL/Blender convention: the camera looks
//! down −z, +x right, +y up; pixel (0, 0) is the top-left corner and ray
//! `(i, j)` passes through the pixel centre `(i + ½, j + ½)`).
//!
//! All quantities are f32 and computed once per ray.

use crate::error::{Error, Result};
use crate::format::Scene;
use crate::sampling::stratified_f32;
use crate::unbounded;
use glam::{Mat3, Vec3};

/// A pinhole camera: intrinsics in pixels and a camera-to-world pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Image width in pixels (≥ 1).
    pub width: u32,
    /// Image height in pixels (≥ 1).
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f32,
    /// Focal length along y, pixels.
    pub fy: f32,
    /// Principal point x, pixels from the left edge.
    pub cx: f32,
    /// Principal point y, pixels from the top edge.
    pub cy: f32,
    /// Camera-to-world rotation (columns: camera x, y, z axes in world).
    pub rotation: Mat3,
    /// Camera centre in world units.
    pub position: Vec3,
}

impl Camera {
    /// Builds a camera from intrinsics and a row-major 3×4 camera-to-world
    /// matrix `[R | t]`. Fails with [`Error::InvalidCamera`] if a value is
    /// not finite, a size or focal length is not positive, or `R` is not a
    /// rotation (orthonormal within 10⁻³, determinant +1).
    pub fn new(width: u32, height: u32, fx: f32, fy: f32, cx: f32, cy: f32, c2w: [[f32; 4]; 3]) -> Result<Self> {
        let finite = [fx, fy, cx, cy].iter().all(|v| v.is_finite()) && c2w.iter().flatten().all(|v| v.is_finite());
        if !finite || width == 0 || height == 0 || fx <= 0.0 || fy <= 0.0 {
            return Err(Error::InvalidCamera);
        }
        let rotation = Mat3::from_cols(
            Vec3::new(c2w[0][0], c2w[1][0], c2w[2][0]),
            Vec3::new(c2w[0][1], c2w[1][1], c2w[2][1]),
            Vec3::new(c2w[0][2], c2w[1][2], c2w[2][2]),
        );
        if !is_rotation(&rotation) {
            return Err(Error::InvalidCamera);
        }
        Ok(Self { width, height, fx, fy, cx, cy, rotation, position: Vec3::new(c2w[0][3], c2w[1][3], c2w[2][3]) })
    }

    /// A camera with square pixels, principal point at the centre, and the
    /// horizontal field of view `fov_x` in radians (Blender's `camera_angle_x`).
    pub fn from_fov(width: u32, height: u32, fov_x: f32, c2w: [[f32; 4]; 3]) -> Result<Self> {
        let f = 0.5 * width as f32 / libm::tanf(0.5 * fov_x);
        Self::new(width, height, f, f, 0.5 * width as f32, 0.5 * height as f32, c2w)
    }

    /// A camera at `eye` looking at `target` with `up`'s direction up in
    /// its image ([`look_at_pose`]), square pixels, principal point at the
    /// centre, horizontal field of view `fov_x` radians. World units and
    /// axes are the model's (see [`crate::orbit`] for which way is up).
    /// Fails with [`Error::InvalidCamera`] if `eye` is `target`, `up` is
    /// along the line of sight or zero, or a value is not finite.
    pub fn look_at(width: u32, height: u32, fov_x: f32, eye: Vec3, target: Vec3, up: Vec3) -> Result<Self> {
        Self::from_fov(width, height, fov_x, look_at_pose(eye, target, up))
    }

    /// Angular size of a pixel, radians: `1/√(fx·fy)` (the footprint of
    /// its rays, [`Ray::with_footprint`]).
    pub fn pixel_angle(&self) -> f32 {
        1.0 / libm::sqrtf(self.fx * self.fy)
    }

    /// Origin and (unnormalised, camera-space `z = −1`) direction of the ray
    /// through the centre of pixel `(i, j)`, in world units.
    pub fn ray(&self, i: u32, j: u32) -> (Vec3, Vec3) {
        self.ray_at(i as f32 + 0.5, j as f32 + 0.5)
    }

    /// The ray through image point `(u, v)` in pixels from the top-left
    /// corner of the image (pixel `(i, j)` covers `[i, i + 1) × [j, j + 1)`).
    pub fn ray_at(&self, u: f32, v: f32) -> (Vec3, Vec3) {
        let x = (u - self.cx) / self.fx;
        let y = -(v - self.cy) / self.fy;
        (self.position, self.rotation * Vec3::new(x, y, -1.0))
    }
}

/// The camera-to-world matrix `[R | t]` (row-major 3×4, as
/// [`Camera::new`] takes it) of a camera at `eye` looking at `target`, with
/// `up` (any vector not along the line of sight) up in its image: camera
/// +x is `forward × up` normalised, +y `right × forward`, +z `−forward`.
/// Degenerate input (`eye = target`, `up` along the line of sight) gives
/// non-finite entries, which [`Camera::new`] refuses.
pub fn look_at_pose(eye: Vec3, target: Vec3, up: Vec3) -> [[f32; 4]; 3] {
    let f = (target - eye).normalize();
    let right = f.cross(up).normalize();
    let (up, back) = (right.cross(f), -f);
    [[right.x, up.x, back.x, eye.x], [right.y, up.y, back.y, eye.y], [right.z, up.z, back.z, eye.z]]
}

/// True if `m` is orthonormal within 10⁻³ with determinant +1.
pub fn is_rotation(m: &Mat3) -> bool {
    let d = *m * m.transpose() - Mat3::IDENTITY;
    let err = d.x_axis.abs().max_element().max(d.y_axis.abs().max_element()).max(d.z_axis.abs().max_element());
    err.is_finite() && err < 1e-3 && (m.determinant() - 1.0).abs() < 1e-3
}

/// The footprint's radius per unit of `t` and of pixel angle, `1/√6`:
/// three or more points spread evenly on a circle of radius `ρ` have the
/// variance `ρ²/2` along each axis, a pixel-wide box `1/12`
/// ([`crate::format::Footprint`]).
pub const FOOTPRINT_RADIUS: f32 = 0.408_248_3;

pub use crate::limits::FOOTPRINT_POINTS;

/// A ray prepared for sampling: what both numeric paths need, per ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin in normalised scene coordinates (bounds ↦ [−1, 1]³).
    pub norm_origin: Vec3,
    /// Direction in normalised scene coordinates (per unit of `t`).
    pub norm_dir: Vec3,
    /// Unit view direction in world space (input of the view branch).
    pub viewdir: Vec3,
    /// Length of the sampling direction: `δ = Δt · dir_len`, world units.
    pub dir_len: f32,
    /// Near bound of `t`: the scene's near plane or the bounds' entry.
    pub near: f32,
    /// Far bound of `t`: the scene's far plane or the bounds' exit.
    pub far: f32,
    /// Unbounded scenes: [`crate::format::Unbounded::linear_until`] (positions are
    /// contracted and samples spaced as [`crate::unbounded`] says); `None` otherwise.
    pub linear_until: Option<f32>,
    /// With a pixel footprint ([`Ray::with_footprint`]): the offsets per
    /// unit of `t`, in normalised coordinates (before any contraction), of
    /// the footprint's points `ρ·t·(cos θₘ·u + sin θₘ·v)`, `θₘ = 2πm/3`;
    /// `None`: the ray is a line.
    pub foot: Option<[Vec3; FOOTPRINT_POINTS]>,
}

impl Ray {
    /// Prepares a world-space ray (`origin`, `dir` with `d.z = −1` in
    /// camera space) for `scene`, mapping to NDC first for forward-facing
    /// scenes, and clips `[near, far]` to the part of the ray inside the
    /// scene bounds (nothing is sampled outside them; in an unbounded scene
    /// the ray keeps the scene's near..far). Returns `None` if
    /// the ray is not finite or degenerate (zero direction, or an NDC ray
    /// parallel to the image plane), or misses the bounds within
    /// `[near, far]`: such a ray shows the background at depth `far`.
    pub fn new(scene: &Scene, origin: Vec3, dir: Vec3) -> Option<Self> {
        if !origin.is_finite() || !dir.is_finite() || dir.length_squared() == 0.0 {
            return None;
        }
        let viewdir = dir.normalize();
        let (o, d) = match scene.ndc {
            Some(n) => ndc_ray(n.width, n.height, n.focal, 1.0, origin, dir)?,
            None => (origin, dir),
        };
        let lo = Vec3::from(scene.bounds_min);
        let hi = Vec3::from(scene.bounds_max);
        let centre = 0.5 * (lo + hi);
        let inv_half = 2.0 / (hi - lo);
        let norm_origin = (o - centre) * inv_half;
        let norm_dir = d * inv_half;
        let linear_until = scene.unbounded.map(|u| u.linear_until);
        let (near, far) = match linear_until {
            Some(_) => (scene.near, scene.far),
            None => {
                // Slab test against [−1, 1]³ in normalised coordinates.
                let inv = Vec3::ONE / norm_dir;
                let t0 = (Vec3::NEG_ONE - norm_origin) * inv;
                let t1 = (Vec3::ONE - norm_origin) * inv;
                (t0.min(t1).max_element().max(scene.near), t0.max(t1).min_element().min(scene.far))
            }
        };
        let r = Self { norm_origin, norm_dir, viewdir, dir_len: d.length(), near, far, linear_until, foot: None };
        let ok = r.norm_origin.is_finite() && r.norm_dir.is_finite() && r.dir_len.is_finite();
        (ok && near < far).then_some(r)
    }

    /// The ray with the footprint of a pixel of angular size `pixel`
    /// (radians: 1/focal length in pixels; see
    /// [`crate::format::Footprint`]), its basis `u`, `v` turned by `phi`
    /// radians about the ray (0 when rendering). `u = normalize(d × e)`
    /// with `e` the world x axis (y when `|d·x| ≥ 0.9`), `v = d × u`, `d`
    /// the view direction. Forward-facing (NDC) scenes, and a `pixel` that
    /// is not finite and positive, leave the ray a line.
    pub fn with_footprint(mut self, scene: &Scene, pixel: f32, phi: f32) -> Self {
        if scene.ndc.is_some() || !(pixel.is_finite() && pixel > 0.0) {
            return self;
        }
        let d = self.viewdir;
        let e = if d.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
        let u = d.cross(e).normalize();
        let v = d.cross(u);
        let (s, c) = (libm::sinf(phi), libm::cosf(phi));
        let (u, v) = (c * u + s * v, c * v - s * u);
        let inv_half = 2.0 / (Vec3::from(scene.bounds_max) - Vec3::from(scene.bounds_min));
        let rho = pixel * FOOTPRINT_RADIUS;
        let foot: [Vec3; FOOTPRINT_POINTS] = core::array::from_fn(|m| {
            let th = core::f32::consts::TAU * m as f32 / FOOTPRINT_POINTS as f32;
            rho * (libm::cosf(th) * u + libm::sinf(th) * v) * inv_half
        });
        self.foot = foot.iter().all(|f| f.is_finite()).then_some(foot);
        self
    }

    /// The footprint's points at parameter `t` (in the order of
    /// [`Ray::foot`]; contracted in an unbounded scene), or `None` for a line.
    #[inline(always)]
    pub fn foot_at(&self, t: f32) -> Option<[[f32; 3]; FOOTPRINT_POINTS]> {
        let foot = self.foot?;
        let p = self.norm_origin + t * self.norm_dir;
        let pts = foot.map(|f| p + t * f);
        Some(pts.map(|q| if self.linear_until.is_some() { unbounded::contract_f32(q) } else { q }.to_array()))
    }

    /// Normalised position at parameter `t` (contracted in an unbounded scene).
    #[inline(always)]
    pub fn at(&self, t: f32) -> Vec3 {
        let p = self.norm_origin + t * self.norm_dir;
        if self.linear_until.is_some() {
            unbounded::contract_f32(p)
        } else {
            p
        }
    }

    /// The `out.len()` stratified samples of the ray's `near..far` (see
    /// [`crate::sampling::stratified_f32`]), spaced as the scene says.
    pub fn stratified(&self, jitter: Option<u32>, out: &mut [f32]) {
        match self.linear_until {
            None => stratified_f32(self.near, self.far, jitter, out),
            Some(lin) => {
                stratified_f32(unbounded::s_of_t(self.near, lin), unbounded::s_of_t(self.far, lin), jitter, out);
                out.iter_mut().for_each(|s| *s = unbounded::t_of_s(*s, lin));
            }
        }
    }
}

/// nerf-pytorch's `ndc_rays`: shifts the origin to the `near` plane and maps
/// the ray to normalised device coordinates, where `t ∈ [0, 1]` spans
/// `near..∞`. Returns `None` for rays parallel to the image plane, when an
/// input is not finite or a size or focal length is not positive, and when
/// the result would not be finite.
pub fn ndc_ray(w: f32, h: f32, focal: f32, near: f32, o: Vec3, d: Vec3) -> Option<(Vec3, Vec3)> {
    let finite = [w, h, focal, near].iter().all(|v| v.is_finite()) && o.is_finite() && d.is_finite();
    if !finite || w <= 0.0 || h <= 0.0 || focal <= 0.0 || d.z == 0.0 {
        return None;
    }
    let t = -(near + o.z) / d.z;
    let o = o + t * d;
    if o.z == 0.0 {
        return None;
    }
    let ax = -1.0 / (w / (2.0 * focal));
    let ay = -1.0 / (h / (2.0 * focal));
    let o2 = Vec3::new(ax * o.x / o.z, ay * o.y / o.z, 1.0 + 2.0 * near / o.z);
    let d2 = Vec3::new(ax * (d.x / d.z - o.x / o.z), ay * (d.y / d.z - o.y / o.z), -2.0 * near / o.z);
    (o2.is_finite() && d2.is_finite()).then_some((o2, d2))
}

#[cfg(test)]
mod tests {
    use super::*;

    const IDENTITY: [[f32; 4]; 3] = [[1., 0., 0., 0.], [0., 1., 0., 0.], [0., 0., 1., 4.]];

    #[test]
    fn centre_ray_looks_down_minus_z() {
        let c = Camera::from_fov(2, 2, 1.0, IDENTITY).unwrap();
        let (o, d) = c.ray(1, 1);
        assert_eq!(o, Vec3::new(0.0, 0.0, 4.0));
        assert!(d.z == -1.0 && d.x > 0.0 && d.y < 0.0);
    }

    #[test]
    fn rejects_non_rigid_and_non_finite() {
        let mut m = IDENTITY;
        m[0][0] = 2.0;
        assert_eq!(Camera::from_fov(4, 4, 1.0, m), Err(Error::InvalidCamera));
        m = IDENTITY;
        m[1][3] = f32::NAN;
        assert_eq!(Camera::from_fov(4, 4, 1.0, m), Err(Error::InvalidCamera));
        assert_eq!(Camera::from_fov(0, 4, 1.0, IDENTITY), Err(Error::InvalidCamera));
    }
}
