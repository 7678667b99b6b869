//! Camera paths for videos: an orbit fitted to the capture ([`fit_orbit`], followed by
//! [`nerf_infer::Orbit`]), the capture's
//! own trajectory smoothed, and nerfstudio's `camera_path.json` (its
//! rendered camera list, read and written, so a path made here can be
//! edited elsewhere and rendered again; or its keyframes, interpolated).
//!
//! Poses are camera-to-world in the model's frame (OpenGL axes, as
//! nerfstudio's), fields of view in degrees.

use crate::error::{CameraError, CameraPathError, Error, FileError, PathEntryError};
use glam::{Mat3, Quat, Vec3};
use nerf_infer::Camera;
use std::path::Path;

pub mod keyframes;
mod orbit;
use keyframes::Keyframe;
pub use orbit::{fit_orbit, orbit_rays};

/// `n ≥ 1` cameras along the trajectory of `cams` (in capture order),
/// smoothed: positions and orientations are Gaussian-weighted means over
/// the capture (σ = a twentieth of its length, at least one camera), so a
/// handheld capture's shake does not reach the video. Each camera has
/// `cams[0]`'s field of view, with `width` pixels across and the height
/// that keeps `cams[0]`'s aspect ratio. No cameras, `n` 0 or `width` 0
/// is an error.
pub fn smooth_trajectory(cams: &[Camera], n: usize, width: u32) -> Result<Vec<Camera>, CameraError> {
    if cams.is_empty() || n == 0 || width == 0 {
        return Err(CameraError::EmptyTrajectory { cameras: cams.len(), frames: n, width });
    }
    let m = cams.len();
    let sigma = (m as f32 / 20.0).max(1.0);
    let c0 = &cams[0];
    let height = ((width as f32 * c0.height as f32 / c0.width as f32).round() as u32).max(1);
    let (sx, sy) = (width as f32 / c0.width as f32, height as f32 / c0.height as f32);
    let q0 = Quat::from_mat3(&c0.rotation);
    (0..n)
        .map(|k| {
            let s = if n < 2 { 0.0 } else { k as f32 * (m - 1) as f32 / (n - 1) as f32 };
            let (mut wsum, mut pos, mut q) = (0.0f32, Vec3::ZERO, Quat::from_xyzw(0.0, 0.0, 0.0, 0.0));
            for (j, c) in cams.iter().enumerate() {
                let w = (-0.5 * ((j as f32 - s) / sigma).powi(2)).exp();
                let cq = Quat::from_mat3(&c.rotation);
                // quaternions q and −q are one rotation: add them on one side
                let cq = if cq.dot(q0) < 0.0 { -cq } else { cq };
                wsum += w;
                pos += w * c.position;
                q += cq * w;
            }
            let r = Mat3::from_quat(q.normalize());
            let c2w = rows(&r, pos / wsum);
            Camera::new(width, height, c0.fx * sx, c0.fy * sy, c0.cx * sx, c0.cy * sy, c2w)
                .map_err(|source| CameraError::Trajectory { index: k, source })
        })
        .collect()
}

fn rows(r: &Mat3, t: Vec3) -> [[f32; 4]; 3] {
    [
        [r.x_axis.x, r.y_axis.x, r.z_axis.x, t.x],
        [r.x_axis.y, r.y_axis.y, r.z_axis.y, t.y],
        [r.x_axis.z, r.y_axis.z, r.z_axis.z, t.z],
    ]
}

/// `cams` as nerfstudio's `camera_path.json` (perspective cameras, their
/// camera-to-world matrices row-major, vertical field of view in degrees),
/// at `fps` frames per second.
pub fn to_camera_path(cams: &[Camera], fps: f32) -> serde_json::Value {
    let (w, h) = cams.first().map_or((1, 1), |c| (c.width, c.height));
    let list: Vec<serde_json::Value> = cams
        .iter()
        .map(|c| {
            let m = rows(&c.rotation, c.position);
            let flat: Vec<f32> = m.iter().flatten().copied().chain([0.0, 0.0, 0.0, 1.0]).collect();
            let fov = 2.0 * (0.5 * c.height as f32 / c.fy).atan().to_degrees();
            serde_json::json!({ "camera_to_world": flat, "fov": fov, "aspect": c.width as f32 / c.height as f32 })
        })
        .collect();
    serde_json::json!({
        "camera_type": "perspective",
        "render_width": w,
        "render_height": h,
        "fps": fps,
        "seconds": cams.len() as f32 / fps,
        "camera_path": list,
    })
}

/// The cameras of a nerfstudio `camera_path.json` at `path`, `width`
/// pixels across (the height from each camera's aspect ratio). Its
/// rendered list `camera_path` when it has one (`camera_to_world` as 16 or
/// 12 numbers row-major, `fov` the vertical field of view in degrees,
/// `aspect` width/height); otherwise its `keyframes` (`matrix`, 16 numbers
/// row-major, or column-major as nerfstudio's first viewer wrote them;
/// `fov`; `aspect`), interpolated over `fps · seconds` frames as nerfstudio
/// does ([`keyframes::interpolate`]). Errors name the file and the camera.
pub fn read_camera_path(path: &Path, width: u32) -> Result<Vec<Camera>, Error> {
    let bad = |reason: CameraPathError| Error::from(FileError::CameraPath { path: path.to_path_buf(), reason });
    let text = crate::util::userfile::read_user_text(path, crate::util::userfile::MAX_JSON, "camera path")?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(CameraPathError::Json(e)))?;
    if let Some(t) = v.get("camera_type").and_then(|t| t.as_str()).filter(|t| *t != "perspective") {
        return Err(bad(CameraPathError::CameraType { found: t.to_string() }));
    }
    if !v.is_object() {
        return Err(bad(CameraPathError::NotAnObject));
    }
    // a field present with a value of the wrong type is an error, not a default
    let number = |key: &'static str| -> Result<Option<f64>, Error> {
        match v.get(key) {
            None | Some(serde_json::Value::Null) => Ok(None),
            Some(x) => x.as_f64().map(Some).ok_or_else(|| bad(CameraPathError::NotANumber { key, value: x.clone() })),
        }
    };
    let default_aspect = match (number("render_width")?, number("render_height")?) {
        (Some(w), Some(h)) if w > 0.0 && h > 0.0 => Some(w / h),
        (Some(width), Some(height)) => return Err(bad(CameraPathError::RenderSize { width, height })),
        _ => None,
    };
    let list = |key: &'static str| -> Result<Option<&Vec<serde_json::Value>>, Error> {
        match v.get(key) {
            None | Some(serde_json::Value::Null) => Ok(None),
            Some(serde_json::Value::Array(l)) => Ok(Some(l)),
            Some(_) => Err(bad(CameraPathError::NotAList { key })),
        }
    };
    let (cams, keyed) = match (list("camera_path")?, list("keyframes")?) {
        (Some(l), _) if !l.is_empty() => (l, false),
        (_, Some(l)) if !l.is_empty() => (l, true),
        (None, None) => return Err(bad(CameraPathError::NoCameras)),
        _ => return Err(bad(CameraPathError::Empty)),
    };
    if cams.len() > 100_000 {
        return Err(bad(CameraPathError::TooMany { count: cams.len() }));
    }
    let what = if keyed { "keyframe" } else { "camera" };
    let parsed = cams
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let bad = |reason: PathEntryError| bad(CameraPathError::Entry { kind: what, index: i, reason });
            let m = matrix(c.get(if keyed { "matrix" } else { "camera_to_world" }))
                .ok_or_else(|| bad(PathEntryError::NoMatrix))?;
            if m.len() != 16 && m.len() != 12 {
                return Err(bad(PathEntryError::MatrixLength { count: m.len() }));
            }
            let m = if keyed && m.len() == 16 { row_major(m) } else { m };
            if m.len() == 16 && [m[12], m[13], m[14], m[15] - 1.0].iter().any(|x| x.abs() > 1e-6) {
                return Err(bad(PathEntryError::BottomRow { row: [m[12], m[13], m[14], m[15]] }));
            }
            let field = |key: &'static str| match c.get(key) {
                None | Some(serde_json::Value::Null) => Ok(None),
                Some(x) => {
                    x.as_f64().map(Some).ok_or_else(|| bad(PathEntryError::NotANumber { key, value: x.clone() }))
                }
            };
            let fov = field("fov")?.ok_or_else(|| bad(PathEntryError::NoFov))?;
            if !(1.0..179.0).contains(&fov) {
                return Err(bad(PathEntryError::Fov { fov }));
            }
            let aspect = field("aspect")?.or(default_aspect).ok_or_else(|| bad(PathEntryError::NoAspect))?;
            if !(0.01..100.0).contains(&aspect) {
                return Err(bad(PathEntryError::Aspect { aspect }));
            }
            let mut c2w = [[0f32; 4]; 3];
            for (r, row) in c2w.iter_mut().enumerate() {
                for (k, v) in row.iter_mut().enumerate() {
                    *v = m[r * 4 + k] as f32;
                }
            }
            let cam =
                perspective(width, fov as f32, aspect as f32, c2w).ok_or_else(|| bad(PathEntryError::NotRigid))?;
            Ok((cam, fov as f32, aspect as f32))
        })
        .collect::<Result<Vec<_>, Error>>()?;
    if !keyed {
        return Ok(parsed.into_iter().map(|p| p.0).collect());
    }
    let fps = number("fps")?.ok_or_else(|| bad(CameraPathError::NoFps))?;
    let seconds = number("seconds")?.ok_or_else(|| bad(CameraPathError::NoSeconds))?;
    if !(fps > 0.0 && seconds > 0.0) {
        return Err(bad(CameraPathError::Timing { fps, seconds }));
    }
    let frames = (fps * seconds).round();
    if !(1.0..=100_000.0).contains(&frames) {
        return Err(bad(CameraPathError::Frames { fps, seconds, frames }));
    }
    let smoothness = number("smoothness_value")?.unwrap_or(0.5);
    if !(-1.0..=1.0).contains(&smoothness) {
        return Err(bad(CameraPathError::Smoothness { value: smoothness }));
    }
    let cycle = match v.get("is_cycle") {
        None | Some(serde_json::Value::Null) => false,
        Some(c) => c.as_bool().ok_or_else(|| bad(CameraPathError::Cycle { value: c.clone() }))?,
    };
    let timing = keyframes::Timing { frames: frames as usize, smoothness: smoothness as f32, cycle };
    let keys: Vec<Keyframe> =
        parsed.iter().map(|(c, fov, _)| Keyframe { rotation: c.rotation, position: c.position, fov: *fov }).collect();
    let aspect = default_aspect.map_or(parsed[0].2, |a| a as f32);
    keyframes::interpolate(&keys, timing)
        .into_iter()
        .enumerate()
        .map(|(i, k)| {
            // the spline may overshoot between keyframes of very different fields of view
            perspective(width, k.fov.clamp(1.0, 179.0), aspect, rows(&k.rotation, k.position))
                .ok_or_else(|| bad(CameraPathError::NotRigid { frame: i }))
        })
        .collect()
}

/// A matrix as a list of numbers, or as a string holding one (nerfstudio's
/// first viewer wrote keyframes so).
fn matrix(m: Option<&serde_json::Value>) -> Option<Vec<f64>> {
    match m? {
        serde_json::Value::String(s) => serde_json::from_str(s).ok(),
        m => serde_json::from_value(m.clone()).ok(),
    }
}

/// A 4×4 rigid transform `m` in row-major order: a column-major one (its
/// translation in numbers 12..15, its last column 0 0 0 1) is transposed.
fn row_major(m: Vec<f64>) -> Vec<f64> {
    let zero = |ix: [usize; 3]| ix.iter().all(|&i| m[i].abs() < 1e-9);
    if zero([3, 7, 11]) && !zero([12, 13, 14]) {
        (0..16).map(|i| m[(i % 4) * 4 + i / 4]).collect()
    } else {
        m
    }
}

/// A pinhole camera `width` pixels across with vertical field of view
/// `fov` degrees and `aspect` = width/height, principal point centred.
fn perspective(width: u32, fov: f32, aspect: f32, c2w: [[f32; 4]; 3]) -> Option<Camera> {
    let height = ((width as f32 / aspect).round() as u32).max(1);
    let f = 0.5 * height as f32 / (0.5 * fov.to_radians()).tan();
    let (w, h) = (width as f32, height as f32);
    Camera::new(width, height, f, f, w / 2.0, h / 2.0, c2w).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam(x: f32, yaw: f32) -> Camera {
        let r = Mat3::from_rotation_z(yaw);
        Camera::new(40, 30, 35.0, 35.0, 20.0, 15.0, rows(&r, Vec3::new(x, 0.0, 0.0))).unwrap()
    }

    #[test]
    fn smoothing_removes_shake_and_keeps_the_path() {
        // a straight walk with alternating sideways shake and a steady turn
        let cams: Vec<Camera> =
            (0..40).map(|i| cam(i as f32 + if i % 2 == 0 { 0.3 } else { -0.3 }, 0.02 * i as f32)).collect();
        let out = smooth_trajectory(&cams, 20, 80).unwrap();
        assert!(smooth_trajectory(&[], 20, 80).is_err() && smooth_trajectory(&cams, 20, 0).is_err());
        assert_eq!((out[0].width, out[0].height), (80, 60));
        assert!((out[0].fx - 70.0).abs() < 1e-4);
        for w in out.windows(2) {
            assert!(w[1].position.x > w[0].position.x, "the walk goes forward");
        }
        // frame 10 of 20 sits at capture index s = 10 · 39 / 19; the ±0.3 shake averages out
        let (mid, s) = (&out[10], 10.0 * 39.0 / 19.0);
        assert!(mid.position.y.abs() < 1e-4 && (mid.position.x - s).abs() < 0.05, "{}", mid.position);
        let yaw = mid.rotation.x_axis.y.atan2(mid.rotation.x_axis.x);
        assert!((yaw - 0.02 * s).abs() < 0.005, "{yaw}");
    }

    #[test]
    fn camera_path_round_trips_through_nerfstudios_format() {
        let cams: Vec<Camera> = (0..5).map(|i| cam(i as f32, 0.3 * i as f32)).collect();
        let d_dir = tempfile::tempdir().unwrap();
        let d = d_dir.path();
        let p = d.join("camera_path.json");
        std::fs::write(&p, to_camera_path(&cams, 24.0).to_string()).unwrap();
        let back = read_camera_path(&p, 40).unwrap();
        for (a, b) in cams.iter().zip(&back) {
            assert_eq!((a.width, a.height), (b.width, b.height));
            assert!((a.fy - b.fy).abs() < 1e-3 && (a.position - b.position).length() < 1e-6);
            assert!((a.rotation.x_axis - b.rotation.x_axis).length() < 1e-6);
        }
        std::fs::write(&p, r#"{"camera_path": [{"camera_to_world": [1, 0, 0]}]}"#).unwrap();
        let e = read_camera_path(&p, 40).unwrap_err().to_string();
        assert!(e.contains("camera_path.json") && e.contains("camera 0") && e.contains("3 numbers"), "{e}");
    }

    #[test]
    fn keyframes_are_interpolated_whichever_viewer_wrote_them() {
        let keys: Vec<Camera> = (0..3).map(|i| cam(i as f32, 0.3 * i as f32)).collect();
        let flat = |c: &Camera, column_major: bool| -> Vec<f32> {
            let m = rows(&c.rotation, c.position);
            let r: Vec<f32> = m.iter().flatten().copied().chain([0.0, 0.0, 0.0, 1.0]).collect();
            if column_major {
                (0..16).map(|i| r[(i % 4) * 4 + i / 4]).collect()
            } else {
                r
            }
        };
        let d_dir = tempfile::tempdir().unwrap();
        let d = d_dir.path();
        let p = d.join("camera_path.json");
        let read = |column_major: bool| {
            let list: Vec<serde_json::Value> = keys
                .iter()
                .map(|c| {
                    let m = flat(c, column_major);
                    // nerfstudio's first viewer wrote the matrix as a string, column-major
                    let m = if column_major { serde_json::json!(format!("{m:?}")) } else { serde_json::json!(m) };
                    serde_json::json!({ "matrix": m, "fov": 40.0, "aspect": 2.0 })
                })
                .collect();
            let json = serde_json::json!({
                "keyframes": list, "camera_path": [], "fps": 5, "seconds": 2,
                "smoothness_value": 0.5, "is_cycle": false, "render_width": 80, "render_height": 40,
            });
            std::fs::write(&p, json.to_string()).unwrap();
            read_camera_path(&p, 40).unwrap()
        };
        let (a, b) = (read(false), read(true));
        assert_eq!(a.len(), 10, "fps × seconds frames");
        assert_eq!((a[0].width, a[0].height), (40, 20));
        assert!((a[0].position - keys[0].position).length() < 1e-5);
        assert!((a[0].rotation.x_axis - keys[0].rotation.x_axis).length() < 1e-5);
        // frame 5 of 10 is at spline time 1: the middle keyframe
        assert!((a[5].position - keys[1].position).length() < 1e-5, "{}", a[5].position);
        for w in a.windows(2) {
            assert!(w[1].position.x > w[0].position.x, "the path moves forward");
        }
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x.position - y.position).length() < 1e-6 && (x.rotation.y_axis - y.rotation.y_axis).length() < 1e-6
            );
        }
        std::fs::write(&p, r#"{"keyframes": [{"matrix": [1, 0]}]}"#).unwrap();
        let e = read_camera_path(&p, 40).unwrap_err().to_string();
        assert!(e.contains("keyframe 0") && e.contains("2 numbers"), "{e}");
    }

    #[test]
    fn a_matrix_with_another_bottom_row_and_huge_times_are_refused_in_a_line_a_reader_can_read() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("path.json");
        let m = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 4, 1, 1, 1, 5];
        let key = serde_json::json!({ "matrix": m, "fov": 40.0, "aspect": 1.0 });
        let file = serde_json::json!({ "keyframes": [key], "fps": 5, "seconds": 1 });
        std::fs::write(&p, file.to_string()).unwrap();
        let e = read_camera_path(&p, 40).unwrap_err().to_string();
        assert!(e.contains("keyframe 0") && e.contains("bottom row is 1 1 1 5, not 0 0 0 1"), "{e}");
        let m = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 4, 0, 0, 0, 1];
        let key = serde_json::json!({ "matrix": m, "fov": 40.0, "aspect": 1.0 });
        let file = serde_json::json!({ "keyframes": [key], "fps": 5, "seconds": 1e308 });
        std::fs::write(&p, file.to_string()).unwrap();
        let e = read_camera_path(&p, 40).unwrap_err().to_string();
        assert!(e.contains("seconds 1e308") && e.len() < 200, "{e}");
    }
}
