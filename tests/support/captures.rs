//! The captures the capture tests make: the built-in scene's COLMAP capture
//! and its instant-ngp twin, JPEG files with EXIF orientation, and how they
//! load.

use nerf_train::dataset::synthetic::{write_colmap, ColmapText, SceneSpec};
use nerf_train::dataset::{load, Format, Lens, LoadOptions, Split};
use std::path::Path;

pub fn spec() -> SceneSpec {
    SceneSpec { size: 16, train: 8, val: 2, test: 0 }
}

pub fn opts(format: Format) -> LoadOptions {
    LoadOptions { format, downscale: 1, holdout: 4, ..LoadOptions::default() }
}

/// Minimal EXIF (big-endian TIFF) holding one tag: orientation `o`.
pub fn exif_orientation(o: u16) -> Vec<u8> {
    let mut v = b"MM\0\x2a\0\0\0\x08\0\x01".to_vec();
    v.extend_from_slice(&[0x01, 0x12, 0x00, 0x03, 0, 0, 0, 1]);
    v.extend_from_slice(&o.to_be_bytes());
    v.extend_from_slice(&[0, 0, 0, 0, 0, 0]);
    v
}

pub fn write_jpeg(path: &Path, img: &image::RgbImage, exif: Option<Vec<u8>>) {
    use image::ImageEncoder;
    let mut buf = Vec::new();
    let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 100);
    if let Some(e) = exif {
        enc.set_exif_metadata(e).unwrap();
    }
    enc.write_image(img, img.width(), img.height(), image::ExtendedColorType::Rgb8).unwrap();
    std::fs::write(path, buf).unwrap();
}

/// An instant-ngp capture from the COLMAP one: transforms.json with the
/// OPENCV camera's intrinsics and distortion keys, two frames whose
/// images were deleted.
pub fn ngp_capture(d: &Path) {
    write_colmap(d, spec(), ColmapText::Binary, false).unwrap();
    // holdout 1: every view is a test view
    let data = load(d, Split::Test, LoadOptions { holdout: 1, ..opts(Format::Colmap) }).unwrap();
    let v0 = &data.views[0];
    let frames: Vec<serde_json::Value> = data
        .views
        .iter()
        .filter(|v| v.camera.height == 16)
        .map(|v| {
            let r = v.camera.rotation;
            let p = v.camera.position;
            let m = [
                [r.x_axis.x, r.y_axis.x, r.z_axis.x, p.x],
                [r.x_axis.y, r.y_axis.y, r.z_axis.y, p.y],
                [r.x_axis.z, r.y_axis.z, r.z_axis.z, p.z],
                [0.0, 0.0, 0.0, 1.0],
            ];
            serde_json::json!({ "file_path": format!("images/{}.jpg", v.name), "transform_matrix": m })
        })
        .collect();
    let Lens::Opencv { k, p } = v0.lens else { panic!("view 0 has the OPENCV camera") };
    let c = &v0.camera;
    let t = serde_json::json!({
        "fl_x": c.fx, "fl_y": c.fy, "cx": c.cx, "cy": c.cy, "w": 16, "h": 16,
        "k1": k[0], "k2": k[1], "p1": p[0], "p2": p[1], "frames": frames,
    });
    std::fs::write(d.join("transforms.json"), t.to_string()).unwrap();
    std::fs::remove_dir_all(d.join("sparse")).unwrap();
    std::fs::remove_file(d.join("images/img_002.jpg")).unwrap();
    std::fs::remove_file(d.join("images/img_004.jpg")).unwrap();
}

/// `d/transforms.json` edited by `f`.
pub fn edit_transforms(d: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let t = std::fs::read_to_string(d.join("transforms.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
    f(&mut v);
    std::fs::write(d.join("transforms.json"), v.to_string()).unwrap();
}
