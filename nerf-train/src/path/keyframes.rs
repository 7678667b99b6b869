//! nerfstudio's camera-path keyframes, interpolated into the cameras of a
//! video as nerfstudio's viewer does: positions and fields of view on a
//! Kochanek–Bartels spline (tension = `smoothness_value`, continuity and
//! bias 0; a closed loop when `is_cycle`, natural ends otherwise), frame
//! `i` of `fps · seconds` at spline time `i / frames` of the whole path.
//! Orientations follow the same spline on unit quaternions (signs aligned
//! along the path), normalised at each frame.

use glam::{Mat3, Quat, Vec3};

/// One keyframe: camera-to-world rotation and position (OpenGL axes, the
/// model's frame), vertical field of view in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Camera-to-world rotation.
    pub rotation: Mat3,
    /// Camera centre, world units.
    pub position: Vec3,
    /// Vertical field of view, degrees.
    pub fov: f32,
}

/// The timing and shape of a keyframed path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// Frames rendered: `round(fps · seconds)`, at least 1.
    pub frames: usize,
    /// Kochanek–Bartels tension in [−1, 1]: 0 is Catmull–Rom, 1 stops at
    /// each keyframe.
    pub smoothness: f32,
    /// The path returns to its first keyframe.
    pub cycle: bool,
}

/// Control point: position xyz, quaternion xyzw, field of view.
type Point = [f32; 8];

fn point(k: &Keyframe) -> Point {
    let q = Quat::from_mat3(&k.rotation);
    let p = k.position;
    [p.x, p.y, p.z, q.x, q.y, q.z, q.w, k.fov]
}

fn quat_dot(a: &Point, b: &Point) -> f32 {
    a[3] * b[3] + a[4] * b[4] + a[5] * b[5] + a[6] * b[6]
}

/// `timing.frames` keyframes along the spline through `keys` (none
/// without keys).
pub fn interpolate(keys: &[Keyframe], timing: Timing) -> Vec<Keyframe> {
    let n = keys.len();
    if n == 0 {
        return Vec::new();
    }
    // the control points in path order, a closed path wrapped one point each side
    let mut pts: Vec<Point> = if timing.cycle {
        let ix = std::iter::once(n - 1).chain(0..n).chain([0, 1 % n]);
        ix.map(|i| point(&keys[i])).collect()
    } else {
        keys.iter().map(point).collect()
    };
    // q and −q are one rotation: keep each quaternion on the side of the one before
    for j in 1..pts.len() {
        if quat_dot(&pts[j], &pts[j - 1]) < 0.0 {
            for v in &mut pts[j][3..7] {
                *v = -*v;
            }
        }
    }
    let tangents = tangents(&pts, timing);
    let (first, segments) = if timing.cycle { (1, n) } else { (0, n - 1) };
    (0..timing.frames)
        .map(|i| {
            let t = segments as f32 * i as f32 / timing.frames as f32;
            let k = (t.floor() as usize).min(segments.saturating_sub(1));
            let s = t - k as f32;
            let v = if segments == 0 {
                pts[0]
            } else {
                hermite(&pts[first + k], &tangents[first + k], &pts[first + k + 1], &tangents[first + k + 1], s)
            };
            let q = Quat::from_xyzw(v[3], v[4], v[5], v[6]).normalize();
            Keyframe { rotation: Mat3::from_quat(q), position: Vec3::new(v[0], v[1], v[2]), fov: v[7] }
        })
        .collect()
}

/// Tangent at each control point: `(1 − tension)/2 · (p[j+1] − p[j−1])`
/// inside, the natural end condition (no curvature) at an open path's
/// ends, a straight line between two keyframes.
fn tangents(pts: &[Point], timing: Timing) -> Vec<Point> {
    let m = pts.len();
    let scale = 0.5 * (1.0 - timing.smoothness);
    let mut tan = vec![[0.0; 8]; m];
    for j in 1..m.saturating_sub(1) {
        tan[j] = std::array::from_fn(|c| scale * (pts[j + 1][c] - pts[j - 1][c]));
    }
    if !timing.cycle && m >= 2 {
        if m == 2 {
            let d: Point = std::array::from_fn(|c| pts[1][c] - pts[0][c]);
            return vec![d, d];
        }
        tan[0] = std::array::from_fn(|c| 0.5 * (3.0 * (pts[1][c] - pts[0][c]) - tan[1][c]));
        tan[m - 1] = std::array::from_fn(|c| 0.5 * (3.0 * (pts[m - 1][c] - pts[m - 2][c]) - tan[m - 2][c]));
    }
    tan
}

/// The cubic Hermite curve from `p0` (tangent `m0`) to `p1` (tangent
/// `m1`) at `s` in [0, 1].
fn hermite(p0: &Point, m0: &Point, p1: &Point, m1: &Point, s: f32) -> Point {
    let (s2, s3) = (s * s, s * s * s);
    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
    let h10 = s3 - 2.0 * s2 + s;
    let h01 = -2.0 * s3 + 3.0 * s2;
    let h11 = s3 - s2;
    std::array::from_fn(|c| h00 * p0[c] + h10 * m0[c] + h01 * p1[c] + h11 * m1[c])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera on the unit circle at angle `a`, looking at the origin.
    fn on_circle(a: f32, fov: f32) -> Keyframe {
        let position = Vec3::new(a.cos(), a.sin(), 0.0);
        let back = position; // OpenGL: the camera looks down −z
        let up = Vec3::Z;
        let right = up.cross(back).normalize();
        Keyframe { rotation: Mat3::from_cols(right, back.cross(right), back), position, fov }
    }

    #[test]
    fn a_closed_path_passes_through_its_keyframes_and_stays_near_the_circle() {
        let keys: Vec<Keyframe> =
            (0..8).map(|k| on_circle(k as f32 * std::f32::consts::FRAC_PI_4, 40.0 + k as f32)).collect();
        let out = interpolate(&keys, Timing { frames: 32, smoothness: 0.0, cycle: true });
        assert_eq!(out.len(), 32);
        for (i, f) in out.iter().enumerate() {
            if i % 4 == 0 {
                let k = &keys[i / 4];
                assert!((f.position - k.position).length() < 1e-5, "frame {i}");
                assert!((f.rotation.z_axis - k.rotation.z_axis).length() < 1e-5, "frame {i}");
                assert!((f.fov - k.fov).abs() < 1e-4, "frame {i}");
            }
            // Catmull–Rom through 8 points of a circle bulges by well under 1 %
            assert!((f.position.length() - 1.0).abs() < 0.01, "frame {i}: radius {}", f.position.length());
            // still looking at the centre: its back axis points along its position
            assert!(f.rotation.z_axis.dot(f.position.normalize()) > 0.999, "frame {i}");
        }
        // the last frame closes the loop towards keyframe 0, not back across the circle
        let last = out[31].position;
        assert!(last.y < 0.0 && last.x > 0.9, "{last}");
    }

    #[test]
    fn an_open_path_starts_at_the_first_keyframe_and_two_keyframes_make_a_line() {
        let (a, b) = (on_circle(0.0, 30.0), on_circle(1.0, 50.0));
        let out = interpolate(&[a, b], Timing { frames: 4, smoothness: 0.5, cycle: false });
        assert!((out[0].position - a.position).length() < 1e-6);
        for (i, f) in out.iter().enumerate() {
            let s = i as f32 / 4.0;
            assert!((f.position - a.position.lerp(b.position, s)).length() < 1e-5, "frame {i}");
            assert!((f.fov - (30.0 + 20.0 * s)).abs() < 1e-4, "frame {i}");
        }
        // one keyframe: every frame is that camera
        let one = interpolate(&[a], Timing { frames: 3, smoothness: 0.5, cycle: false });
        assert!(one.iter().all(|f| (f.position - a.position).length() < 1e-6 && f.fov == 30.0));
    }

    #[test]
    fn a_path_without_keyframes_has_no_frames() {
        for cycle in [false, true] {
            assert!(interpolate(&[], Timing { frames: 8, smoothness: 0.0, cycle }).is_empty());
        }
    }
}
