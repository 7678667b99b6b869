//! Writes posed cameras in nerfstudio's layout, as `ns-process-data`
//! leaves a COLMAP capture (the reader is [`load_ngp`](super::load_ngp)):
//! `transforms.json` with each frame's photo (`images/NAME`), its
//! camera-to-world matrix (OpenGL axes) and its intrinsics and lens, and
//! with sparse points `sparse_pc.ply` named by `ply_file_path`. Without
//! points the file is what instant-ngp's `colmap2nerf` writes: cameras only.

use super::capture::CaptureView;
use super::lens::Lens;
use super::types::DataError;
use glam::DVec3;
use std::path::Path;

/// Writes `dir/transforms.json` for `views` (in their order), and with
/// `points` (capture space) `dir/sparse_pc.ply` as an ASCII PLY of
/// vertices. The photos are not written: each frame names
/// `images/` and the photo's file name. A lens nerfstudio's `OPENCV` and
/// `OPENCV_FISHEYE` cannot express (`k4..k6` of COLMAP's `FULL_OPENCV`,
/// `THIN_PRISM_FISHEYE`) is refused, naming the photo.
pub fn write_transforms(dir: &Path, views: &[CaptureView], points: Option<&[DVec3]>) -> Result<(), DataError> {
    let path = dir.join("transforms.json");
    if views.is_empty() {
        return Err(DataError::new(&path, "no cameras to write"));
    }
    let frames = views.iter().map(frame).collect::<Result<Vec<_>, _>>()?;
    let mut t = serde_json::json!({ "frames": frames });
    if let Some(points) = points {
        let ply = dir.join("sparse_pc.ply");
        let mut s = format!(
            "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
             end_header\n",
            points.len()
        );
        points.iter().for_each(|p| s.push_str(&format!("{} {} {}\n", p.x, p.y, p.z)));
        std::fs::write(&ply, s).map_err(|e| DataError::new(&ply, format!("cannot write: {e}")))?;
        t["ply_file_path"] = "sparse_pc.ply".into();
    }
    let text = serde_json::to_string_pretty(&t).map_err(|e| DataError::new(&path, format!("cannot encode: {e}")))?;
    std::fs::write(&path, text).map_err(|e| DataError::new(&path, format!("cannot write: {e}")))
}

/// One frame: its photo, camera-to-world matrix and camera, as nerfstudio
/// writes a frame's own intrinsics.
fn frame(v: &CaptureView) -> Result<serde_json::Value, DataError> {
    let (r, t) = v.pose;
    let name = v.image.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let rows: Vec<[f64; 4]> = (0..3).map(|a| [r.x_axis[a], r.y_axis[a], r.z_axis[a], t[a]]).collect();
    let k = &v.intrinsics;
    let mut f = serde_json::json!({
        "file_path": format!("images/{name}"),
        "transform_matrix": [rows[0], rows[1], rows[2], [0.0, 0.0, 0.0, 1.0]],
        "fl_x": k.focal[0], "fl_y": k.focal[1], "cx": k.centre[0], "cy": k.centre[1],
        "w": k.size[0], "h": k.size[1],
    });
    let coefficients =
        match v.lens {
            Lens::Pinhole => vec![],
            Lens::Opencv { k, p } if k[3..] == [0.0; 3] => {
                vec![("k1", k[0]), ("k2", k[1]), ("k3", k[2]), ("p1", p[0]), ("p2", p[1])]
            }
            Lens::Fisheye { k } => vec![("k1", k[0]), ("k2", k[1]), ("k3", k[2]), ("k4", k[3])],
            _ => return Err(DataError::new(
                &v.image,
                "its lens (COLMAP's FULL_OPENCV with k4..k6, or THIN_PRISM_FISHEYE) is one nerfstudio's OPENCV and \
                 OPENCV_FISHEYE cannot hold: undistort the photos first (colmap image_undistorter)",
            )),
        };
    f["camera_model"] = if matches!(v.lens, Lens::Fisheye { .. }) { "OPENCV_FISHEYE" } else { "OPENCV" }.into();
    for (key, value) in coefficients {
        f[key] = value.into();
    }
    Ok(f)
}
