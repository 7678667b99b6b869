//! The scene fitted from a real capture: which kind of capture it is, and
//! the frame, scale and bounds the model works in, from the cameras (and
//! the sparse points of a structure-from-motion model, when there are
//! some), not assumed.
//!
//! - Up is the mean of the cameras' up axes; the fitted frame puts it on +z
//!   (as Blender scenes, so orbits and the occupancy grid work as there).
//! - The centre is the point nearest to every camera's optical axis (least
//!   squares): where an inward-looking capture looks.
//! - The scale puts the median camera at distance 1 from the centre.
//! - A capture whose cameras all look nearly the same way ([`view_spread`]
//!   below 0.1: viewing directions within about 18° RMS of a common one)
//!   is forward-facing and keeps LLFF's NDC treatment; any other looks
//!   inward (an arc of 90° already spreads 0.2).
//! - An inward capture is modelled `unbounded` unless told otherwise: the
//!   bounds hold the object box (below) and the cameras, and space beyond
//!   them is contracted ([`nerf_infer::unbounded`]): rays run out to 1000
//!   times the farthest a camera sees inside the bounds, so that the floor,
//!   walls and distant things a photo shows have a place. The bounds leave
//!   the surroundings to the contraction rather than hold them at full
//!   resolution: the grid's cells are spent on what the cameras look at.
//!   (With the object box alone, everything outside it is black, and a
//!   walked-around capture scores far lower that way.) The `object`
//!   box is the 2nd–98th percentile extent of the sparse points inside the
//!   camera ring (or ±0.5 without points): for captures of an object on a
//!   black background.
//! - Near: half the distance from a camera to the nearest things it sees
//!   (the 1st percentile of the depths of the sparse points within 60° of
//!   the cameras' optical axes), at most [`MAX_NEAR`] and at least [`MIN_NEAR`]; `MAX_NEAR`
//!   without points. Density right in front of a lens is seen by that
//!   camera alone and lets the model paint its photo there.

use glam::{DMat3, DVec3};
use nerf_infer::format::{CameraConvention, Scene, Unbounded};

/// Farthest `far` of an unbounded scene (fitted units: the median camera
/// is 1 from the centre), well inside the fixed-point path's 30 000.
const UNBOUNDED_FAR: f64 = 10_000.0;

/// Largest near plane, fitted units (a fifth of the median camera's distance to the centre).
pub const MAX_NEAR: f64 = 0.2;

/// Smallest near plane, fitted units.
pub const MIN_NEAR: f64 = 0.01;

/// Half the side of the object box of a capture with fewer than
/// [`MIN_POINTS`] sparse points inside the camera ring, fitted units: the
/// object taken to fill the middle of the ring.
pub const OBJECT_HALF_WITHOUT_POINTS: f64 = 0.5;

/// Sparse points inside the camera ring the object box is taken from
/// (their 2nd–98th percentile extent); with fewer, the box is
/// ±[`OBJECT_HALF_WITHOUT_POINTS`].
pub const MIN_POINTS: usize = 20;

/// What a capture without sparse points is fitted to instead, for the
/// loaders' notes: the object box and the near plane these take.
pub fn without_points() -> String {
    format!(
        "the object box taken as ±{OBJECT_HALF_WITHOUT_POINTS} of the median camera distance about the cameras' \
         focus and the near plane at its largest, {MAX_NEAR} of that distance"
    )
}

/// How to model the space a capture shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum SceneKind {
    /// Decide from the cameras and points (the module doc says how).
    #[default]
    Auto,
    /// An object seen from all around on a black background, in a box around it.
    Object,
    /// Forward-facing: rays in NDC (LLFF).
    Forward,
    /// Seen from all around, with its surroundings: bounds holding the
    /// object and the cameras, and the rest of space contracted around
    /// them (the default for inward captures).
    Unbounded,
}

/// A camera-to-world pose in the OpenGL convention (columns: right, up,
/// back) with its centre, world units.
pub type Pose = (DMat3, DVec3);

/// The similarity that takes capture coordinates into the fitted frame,
/// and the scene there.
#[derive(Clone, Debug)]
pub struct Fitted {
    /// The kind chosen (never [`SceneKind::Auto`]).
    pub kind: SceneKind,
    /// Capture → fitted rotation.
    pub rotation: DMat3,
    /// Capture-space point that becomes the origin.
    pub centre: DVec3,
    /// Capture units → fitted units.
    pub scale: f64,
    /// Bounds, near/far and background in the fitted frame (for
    /// [`SceneKind::Forward`], NDC parameters are set by the loader).
    pub scene: Scene,
}

impl Fitted {
    /// `pose` in the fitted frame as a row-major 3×4 camera-to-world matrix.
    pub fn apply(&self, pose: &Pose) -> [[f32; 4]; 3] {
        pose_rows(&(self.rotation * pose.0, self.rotation * (pose.1 - self.centre) * self.scale))
    }
}

/// `pose` as a row-major 3×4 camera-to-world matrix `[R | t]`, f32.
pub fn pose_rows((r, t): &Pose) -> [[f32; 4]; 3] {
    [
        [r.x_axis.x as f32, r.y_axis.x as f32, r.z_axis.x as f32, t.x as f32],
        [r.x_axis.y as f32, r.y_axis.y as f32, r.z_axis.y as f32, t.y as f32],
        [r.x_axis.z as f32, r.y_axis.z as f32, r.z_axis.z as f32, t.z as f32],
    ]
}

/// How far the unit viewing directions `f` spread around their principal
/// direction: `1 − λmax(mean f fᵀ)`, the mean squared sine of their angle
/// to it; 0 when all cameras look the same way, 2/3 when they look every way.
pub fn view_spread(poses: &[Pose]) -> f64 {
    let dirs: Vec<DVec3> = poses.iter().map(|p| -p.0.z_axis.normalize_or_zero()).collect();
    let n = dirs.len().max(1) as f64;
    let s = dirs.iter().fold(DMat3::ZERO, |m, f| m + DMat3::from_cols(*f * f.x, *f * f.y, *f * f.z)) * (1.0 / n);
    // power iteration from the mean direction (or +z): S is symmetric positive semi-definite
    let mut v = dirs.iter().sum::<DVec3>().try_normalize().unwrap_or(DVec3::Z);
    for _ in 0..50 {
        match (s * v).try_normalize() {
            Some(w) => v = w,
            None => break,
        }
    }
    1.0 - v.dot(s * v)
}

/// The point nearest (least squares) to every camera's optical axis, or
/// `None` if the axes are (nearly) parallel.
pub fn focus_point(poses: &[Pose]) -> Option<DVec3> {
    let mut a = DMat3::ZERO;
    let mut b = DVec3::ZERO;
    for (r, c) in poses {
        let f = -r.z_axis.normalize_or_zero();
        let m = DMat3::IDENTITY - DMat3::from_cols(f * f.x, f * f.y, f * f.z);
        a += m;
        b += m * *c;
    }
    // a well-posed system has all eigenvalues well away from 0: compare
    // the determinant with the scale of the matrix
    let scale = a.x_axis.length() + a.y_axis.length() + a.z_axis.length();
    let det = a.determinant();
    (det.is_finite() && det.abs() > 1e-6 * scale.powi(3)).then(|| a.inverse() * b)
}

/// The `q`-quantile (`0..=1`) of `v` (sorted in place); `v` not empty.
fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// A rotation taking `up` to +z (and keeping the rest of the frame as
/// close as a shortest-arc rotation does).
fn up_to_z(up: DVec3) -> DMat3 {
    DMat3::from_quat(glam::DQuat::from_rotation_arc(up.normalize(), DVec3::Z))
}

/// The depths along each camera's optical axis (capture units) of every
/// `step`-th of `points` that the camera has in front of it within the
/// cone whose angle to the axis has a cosine above `min_cos` (0: anywhere
/// in front); non-finite ones left out.
pub fn point_depths(poses: &[Pose], points: &[DVec3], step: usize, min_cos: f64) -> Vec<f64> {
    poses
        .iter()
        .flat_map(|(r, eye)| {
            let forward = -r.z_axis.normalize_or_zero();
            points.iter().step_by(step.max(1)).filter_map(move |&q| {
                let d = (q - *eye).dot(forward);
                (d.is_finite() && d > min_cos * (q - *eye).length()).then_some(d)
            })
        })
        .collect()
}

/// The near plane (fitted units) of the module doc: half the 1st
/// percentile of the depths of `points` within 60° of the axes of the
/// cameras `poses` (capture space, `scale` capture → fitted units), within
/// [`MIN_NEAR`]..=[`MAX_NEAR`].
fn near_plane(poses: &[Pose], points: &[DVec3], scale: f64) -> f64 {
    // at most about 2 million camera–point pairs: every k-th point
    let step = points.len() * poses.len() / 2_000_000;
    let mut depths = point_depths(poses, points, step, 0.5);
    if depths.len() < 20 {
        return MAX_NEAR;
    }
    (0.5 * scale * quantile(&mut depths, 0.01)).clamp(MIN_NEAR, MAX_NEAR)
}

/// Fits the scene to `poses` and the capture's sparse `points` (may be
/// empty), with `kind` forced unless `Auto`; `None` without poses.
pub fn fit_scene(poses: &[Pose], points: &[DVec3], kind: SceneKind) -> Option<Fitted> {
    if poses.is_empty() {
        return None;
    }
    let forward = view_spread(poses) < 0.1;
    let mean_pos = poses.iter().map(|p| p.1).sum::<DVec3>() / poses.len() as f64;
    let centre = match focus_point(poses) {
        Some(c) if !forward => c,
        _ => mean_pos,
    };
    let up: DVec3 = poses.iter().map(|p| p.0.y_axis).sum();
    let up = if up.length() > 1e-9 { up } else { DVec3::Z };
    let rotation = up_to_z(up);
    let mut dist: Vec<f64> = poses.iter().map(|p| (p.1 - centre).length()).collect();
    let radius = quantile(&mut dist, 0.5);
    let scale = if radius > 1e-9 && radius.is_finite() { 1.0 / radius } else { 1.0 };
    let to_fit = |p: DVec3| rotation * (p - centre) * scale;
    let inner: Vec<DVec3> = points.iter().map(|&p| to_fit(p)).filter(|p| p.is_finite() && p.length() < 1.0).collect();
    let kind = match kind {
        SceneKind::Auto if forward => SceneKind::Forward,
        SceneKind::Auto => SceneKind::Unbounded,
        k => k,
    };
    let extent = |pts: &[DVec3], lo_q: f64, hi_q: f64| -> ([f64; 3], [f64; 3]) {
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for a in 0..3 {
            let mut v: Vec<f64> = pts.iter().map(|p| p[a]).collect();
            lo[a] = quantile(&mut v, lo_q);
            hi[a] = quantile(&mut v, hi_q);
        }
        (lo, hi)
    };
    let h = OBJECT_HALF_WITHOUT_POINTS;
    let (mut lo, mut hi) = if inner.len() >= MIN_POINTS { extent(&inner, 0.02, 0.98) } else { ([-h; 3], [h; 3]) };
    if kind == SceneKind::Unbounded {
        // the bounds hold the object and the cameras; the rest of space is contracted
        let cams: Vec<DVec3> = poses.iter().map(|p| to_fit(p.1)).collect();
        let (clo, chi) = extent(&cams, 0.0, 1.0);
        for a in 0..3 {
            lo[a] = lo[a].min(clo[a]);
            hi[a] = hi[a].max(chi[a]);
        }
    }
    // pad by 10 % of the size, at least 0.05 per side
    for a in 0..3 {
        let pad = (0.1 * (hi[a] - lo[a])).max(0.05);
        lo[a] -= pad;
        hi[a] += pad;
    }
    // far: the farthest any camera can see inside the box
    let corners =
        (0..8).map(|i| DVec3::new([lo[0], hi[0]][i & 1], [lo[1], hi[1]][(i >> 1) & 1], [lo[2], hi[2]][i >> 2]));
    let far = poses
        .iter()
        .flat_map(|p| corners.clone().map(move |c| (c - to_fit(p.1)).length()))
        .fold(0.0f64, f64::max)
        .max(0.1);
    // unbounded: samples evenly spaced up to that distance, then evenly in 1/t out to 1000 times it
    let unbounded = (kind == SceneKind::Unbounded).then_some(Unbounded { linear_until: far as f32 });
    let scene = Scene {
        bounds_min: lo.map(|v| v as f32),
        bounds_max: hi.map(|v| v as f32),
        near: near_plane(poses, points, scale) as f32,
        far: if unbounded.is_some() { (1000.0 * far).min(UNBOUNDED_FAR) as f32 } else { far as f32 },
        white_background: false,
        convention: CameraConvention::OpenGl,
        ndc: None,
        unbounded,
    };
    Some(Fitted { kind, rotation, centre, scale, scene })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` cameras on a ring of radius `r` around `c`, 0.3 r above it
    /// (+y up), looking at `c`.
    fn ring(n: usize, r: f64, c: DVec3) -> Vec<Pose> {
        (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * std::f64::consts::TAU;
                let pos = c + DVec3::new(r * a.cos(), 0.3 * r, r * a.sin());
                let back = (pos - c).normalize();
                let right = DVec3::Y.cross(back).normalize();
                (DMat3::from_cols(right, back.cross(right), back), pos)
            })
            .collect()
    }

    #[test]
    fn ring_capture_is_centred_scaled_and_turned_z_up() {
        let c = DVec3::new(3.0, -2.0, 5.0);
        let poses = ring(12, 4.0, c);
        let f = fit_scene(&poses, &[], SceneKind::Auto).unwrap();
        assert_eq!(f.kind, SceneKind::Unbounded);
        assert!((f.centre - c).length() < 1e-9, "centre {:?}", f.centre);
        let m = f.apply(&poses[0]);
        let pos = DVec3::new(m[0][3] as f64, m[1][3] as f64, m[2][3] as f64);
        assert!((pos.length() - 1.0).abs() < 1e-6);
        // world up (+y of this capture, tilted by the cameras' pitch on average) is +z now
        assert!((f.rotation * DVec3::Y).z > 0.9);
    }

    #[test]
    fn forward_and_unbounded_are_detected() {
        let poses: Vec<Pose> =
            (0..9).map(|i| (DMat3::IDENTITY, DVec3::new((i % 3) as f64 * 0.1, (i / 3) as f64 * 0.1, 0.0))).collect();
        assert_eq!(fit_scene(&poses, &[], SceneKind::Auto).unwrap().kind, SceneKind::Forward);
        let poses = ring(12, 4.0, DVec3::ZERO);
        // points on walls at 3× the camera distance, and a few on the object
        let mut pts: Vec<DVec3> =
            (0..100).map(|i| DVec3::new(12.0 * (i as f64).cos(), 0.0, 12.0 * (i as f64).sin())).collect();
        pts.extend((0..50).map(|i| DVec3::splat(0.01 * i as f64)));
        let f = fit_scene(&poses, &pts, SceneKind::Auto).unwrap();
        assert_eq!(f.kind, SceneKind::Unbounded);
        // the box holds the cameras (at 1 in fitted units), the walls (at 3) are left to the contraction
        let hi = f.scene.bounds_max[0];
        assert!((1.0..1.5).contains(&hi), "the box holds the cameras, not the walls: {:?}", f.scene.bounds_max);
        // nothing in front of a camera nearer than the object (0.9 away or more): the near plane's cap
        assert_eq!(f.scene.near, MAX_NEAR as f32);
        assert_eq!(fit_scene(&poses, &pts, SceneKind::Object).unwrap().kind, SceneKind::Object);
        let obj = fit_scene(&poses, &pts, SceneKind::Object).unwrap();
        assert!(obj.scene.bounds_max[0] < 0.5, "the object box holds the object only: {:?}", obj.scene.bounds_max);
    }

    #[test]
    fn a_capture_without_cameras_has_no_scene() {
        assert!(fit_scene(&[], &[DVec3::ZERO], SceneKind::Auto).is_none());
    }

    #[test]
    fn the_near_plane_is_half_the_depth_of_the_nearest_points_seen() {
        let poses = ring(12, 4.0, DVec3::ZERO);
        // a patch of 30 points 0.4 (world; 0.1 fitted) in front of every camera, among many points on the object
        let mut pts: Vec<DVec3> = poses
            .iter()
            .flat_map(|(r, c)| (0..30).map(move |k| *c - 0.4 * r.z_axis + 0.001 * k as f64 * r.x_axis))
            .collect();
        pts.extend(
            (0..2000).map(|i| DVec3::new((i % 10) as f64 * 0.05, (i / 10 % 10) as f64 * 0.05, (i / 100) as f64 * 0.02)),
        );
        let near = fit_scene(&poses, &pts, SceneKind::Auto).unwrap().scene.near;
        // the patches are over 1 % of the depths: the 1st percentile is theirs
        assert!((0.045..0.055).contains(&near), "{near}");
        assert_eq!(fit_scene(&poses, &[], SceneKind::Auto).unwrap().scene.near, MAX_NEAR as f32);
    }
}
