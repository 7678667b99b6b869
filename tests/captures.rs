//! Real-capture inputs on data the tests make: COLMAP models (binary and
//! text, several cameras, lens distortion, unregistered images, refused
//! camera models), JPEG with EXIF orientation, instant-ngp files with
//! missing frames, distortion keys and masks, the fitted scene, and
//! captures whose rays miss the scene.

mod support;

use nerf_infer::Orbit;
use nerf_train::dataset::synthetic::{write_colmap, ColmapText, SceneSpec};
use nerf_train::dataset::{load, load_rgb, Format, Lens, LoadOptions, SceneKind, Split};
use std::path::{Path, PathBuf};
use support::cli::{nerf, s, tmp};

fn spec() -> SceneSpec {
    SceneSpec { size: 16, train: 8, val: 2, test: 0 }
}

fn opts(format: Format) -> LoadOptions {
    LoadOptions { format, downscale: 1, holdout: 4, ..LoadOptions::default() }
}

#[test]
fn colmap_binary_and_text_models_give_identical_cameras() {
    let d = tmp("colmap-bin-txt");
    write_colmap(&d.join("bin"), spec(), ColmapText::Binary, false).unwrap();
    write_colmap(&d.join("txt"), spec(), ColmapText::Text, false).unwrap();
    assert!(d.join("bin/sparse/0/images.bin").is_file() && d.join("txt/sparse/0/images.txt").is_file());
    for split in [Split::Train, Split::Test] {
        let a = load(&d.join("bin"), split, opts(Format::Auto)).unwrap();
        let b = load(&d.join("txt"), split, opts(Format::Colmap)).unwrap();
        assert_eq!(a.views.len(), b.views.len());
        assert_eq!(a.scene, b.scene);
        for (u, v) in a.views.iter().zip(&b.views) {
            assert_eq!((&u.name, u.camera, u.lens), (&v.name, v.camera, v.lens));
            assert_eq!(u.rgb, v.rgb);
        }
    }
    // 10 images, every 4th held out: 0, 4, 8
    assert_eq!(load(&d.join("bin"), Split::Test, opts(Format::Auto)).unwrap().views.len(), 3);
}

#[test]
fn colmap_capture_keeps_each_camera_and_bends_rays_through_its_lens() {
    let d = tmp("colmap-cams");
    write_colmap(&d, spec(), ColmapText::Binary, false).unwrap();
    let data = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    // even images: OPENCV 16×16 with distortion; odd: PINHOLE 16×12
    let sizes: Vec<(u32, u32)> = data.views.iter().map(|v| (v.camera.width, v.camera.height)).collect();
    assert!(sizes.contains(&(16, 16)) && sizes.contains(&(16, 12)), "{sizes:?}");
    for v in &data.views {
        let distorted = v.camera.height == 16;
        assert_eq!(v.lens != Lens::Pinhole, distorted, "{}: {:?}", v.name, v.lens);
        // each pixel's ray, projected back through the lens, lands on the pixel centre
        for (x, y) in [(0, 0), (15, 0), (7, 5), (15, v.camera.height - 1)] {
            let (_, dir) = v.ray(x, y);
            let c = v.camera.rotation.transpose() * dir;
            let (px, py) = ((c.x / -c.z) as f64, (-c.y / -c.z) as f64);
            let (xd, yd) = v.lens.distort(px, py);
            let u = xd * v.camera.fx as f64 + v.camera.cx as f64 - 0.5;
            let w = yd * v.camera.fy as f64 + v.camera.cy as f64 - 0.5;
            assert!((u - x as f64).abs() < 1e-3 && (w - y as f64).abs() < 1e-3, "{}: ({x},{y}) → ({u},{w})", v.name);
        }
    }
    // ignoring the lens makes every view a pinhole
    let flat = load(&d, Split::Train, LoadOptions { lens: false, ..opts(Format::Auto) }).unwrap();
    assert!(flat.views.iter().all(|v| v.lens == Lens::Pinhole));
    // undistorting at load too, resampling only the distorted camera's photos
    let resampled = load(&d, Split::Train, LoadOptions { undistort: true, ..opts(Format::Auto) }).unwrap();
    for (r, v) in resampled.views.iter().zip(&data.views) {
        assert_eq!(r.lens, Lens::Pinhole, "{}", r.name);
        let moved = r.rgb.iter().zip(&v.rgb).any(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 1e-3));
        assert_eq!(moved, v.lens != Lens::Pinhole, "{}", r.name);
    }
}

#[test]
fn colmap_refuses_unsupported_camera_models_by_name_and_counts_unregistered_images() {
    let d = tmp("colmap-bad");
    write_colmap(&d, spec(), ColmapText::Text, false).unwrap();
    std::fs::copy(d.join("images/img_000.jpg"), d.join("images/extra.jpg")).unwrap();
    let data = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert!(data.notes.iter().any(|n| n.contains("1 images not registered")), "{:?}", data.notes);
    let cams = d.join("sparse/0/cameras.txt");
    let text = std::fs::read_to_string(&cams).unwrap();
    let fov: String = text
        .lines()
        .map(|l| if l.starts_with("2 ") { "2 EUCM 16 12 10 10 8 6 0.5 1.0".to_string() } else { l.to_string() })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(&cams, fov).unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("EUCM") && e.contains("not supported") && e.contains("camera 2"), "{e}");
    assert!(!e.contains('\n'));
    std::fs::write(&cams, text).unwrap();
    // a photo turned on its side (12×16 where its camera is 16×12) is refused by name
    let img_1 = d.join("images/img_001.jpg");
    let good_1 = std::fs::read(&img_1).unwrap();
    write_jpeg(&img_1, &image::RgbImage::new(12, 16), None);
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("img_001.jpg") && e.contains("16x12") && e.contains("shape"), "{e}");
    std::fs::write(&img_1, good_1).unwrap();
    // an image file the model registers but the folder lacks is named
    std::fs::remove_file(d.join("images/img_003.jpg")).unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("img_003.jpg") && e.contains("not found"), "{e}");
}

#[test]
fn scene_is_fitted_to_the_capture() {
    let d = tmp("colmap-fit");
    write_colmap(&d.join("object"), spec(), ColmapText::Binary, false).unwrap();
    write_colmap(&d.join("room"), spec(), ColmapText::Binary, true).unwrap();
    let object = load(&d.join("object"), Split::Train, LoadOptions { scene: SceneKind::Object, ..opts(Format::Auto) });
    let object = object.unwrap();
    let room = load(&d.join("room"), Split::Train, opts(Format::Auto)).unwrap();
    // cameras at distance 1 from the fitted centre; the object box inside their ring, the room's (auto:
    // unbounded) around them
    for v in object.views.iter().chain(&room.views) {
        assert!((v.camera.position.length() - 1.0).abs() < 0.35, "{}: {}", v.name, v.camera.position);
    }
    let inside = |b: [f32; 3]| b.iter().all(|c| c.abs() < 0.9);
    assert!(inside(object.scene.bounds_min) && inside(object.scene.bounds_max), "{:?}", object.scene);
    // the room's box holds every camera (its walls, three times farther out, are left to the contraction)
    for v in &room.views {
        let p = v.camera.position.to_array();
        let held = (0..3).all(|k| room.scene.bounds_min[k] < p[k] && p[k] < room.scene.bounds_max[k]);
        assert!(held && room.scene.bounds_max.iter().all(|&c| c < 2.0), "{}: {p:?} {:?}", v.name, room.scene);
    }
    assert!(object.scene.ndc.is_none() && room.scene.ndc.is_none());
    // --scene object on the room capture keeps the box on the object
    let forced = load(&d.join("room"), Split::Train, LoadOptions { scene: SceneKind::Object, ..opts(Format::Auto) });
    assert!(inside(forced.unwrap().scene.bounds_max));
    // the fitted scene is seen by the training rays
    assert!(object.ray_hit_fraction() > 0.5 && room.ray_hit_fraction() > 0.99);
}

#[test]
fn colmap_rig_folders_keep_every_photo_apart_and_count_their_unregistered_images() {
    let d = tmp("colmap-rig");
    write_colmap(&d, spec(), ColmapText::Text, false).unwrap();
    let flat = load(&d, Split::Test, LoadOptions { holdout: 1, ..opts(Format::Auto) }).unwrap();
    // a rig's layout: img_00K.jpg moved to cam1/ (K even) or cam2/ (K odd) as img_00{K/2}.jpg, so each
    // file name is in both folders; one image named from the capture's folder (`images/…`), as a model
    // made with the capture's folder as COLMAP's image path names it
    let path = d.join("sparse/0/images.txt");
    let text = std::fs::read_to_string(&path).unwrap();
    let moved = |name: &str| {
        let k: usize = name.trim_start_matches("img_").trim_end_matches(".jpg").parse().unwrap();
        format!("cam{}/img_{:03}.jpg", 1 + k % 2, k / 2)
    };
    std::fs::create_dir_all(d.join("images/cam1")).unwrap();
    std::fs::create_dir_all(d.join("images/cam2")).unwrap();
    let mut out = Vec::new();
    for l in text.lines() {
        match l.split_whitespace().last().filter(|n| n.starts_with("img_") && n.ends_with(".jpg")) {
            Some(name) => {
                let to = moved(name);
                std::fs::rename(d.join("images").join(name), d.join("images").join(&to)).unwrap();
                let to = if to == "cam1/img_000.jpg" { format!("images/{to}") } else { to };
                out.push(format!("{} {to}", l.rsplit_once(' ').unwrap().0));
            }
            None => out.push(l.to_string()),
        }
    }
    std::fs::write(&path, out.join("\n")).unwrap();
    std::fs::copy(d.join("images/cam2/img_000.jpg"), d.join("images/cam2/extra.jpg")).unwrap();
    let rig = load(&d, Split::Test, opts(Format::Auto)).unwrap();
    let names: Vec<&str> = rig.views.iter().map(|v| v.name.as_str()).collect();
    // every 4th in name order (cam1/…, cam2/…, then images/cam1/img_000.jpg) held out: images 2, 1 and 9
    assert_eq!(names, ["cam1_img_001", "cam2_img_000", "cam2_img_004"]);
    for (u, k) in rig.views.iter().zip([2, 1, 9]) {
        let v = flat.views.iter().find(|v| v.name == format!("img_{k:03}")).expect("in the flat layout");
        assert_eq!((u.camera, &u.rgb), (v.camera, &v.rgb), "{}", u.name);
    }
    let train = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert!(train.notes.iter().any(|n| n.contains("1 images not registered")), "{:?}", train.notes);
}

/// Minimal EXIF (big-endian TIFF) holding one tag: orientation `o`.
fn exif_orientation(o: u16) -> Vec<u8> {
    let mut v = b"MM\0\x2a\0\0\0\x08\0\x01".to_vec();
    v.extend_from_slice(&[0x01, 0x12, 0x00, 0x03, 0, 0, 0, 1]);
    v.extend_from_slice(&o.to_be_bytes());
    v.extend_from_slice(&[0, 0, 0, 0, 0, 0]);
    v
}

fn write_jpeg(path: &Path, img: &image::RgbImage, exif: Option<Vec<u8>>) {
    use image::ImageEncoder;
    let mut buf = Vec::new();
    let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 100);
    if let Some(e) = exif {
        enc.set_exif_metadata(e).unwrap();
    }
    enc.write_image(img, img.width(), img.height(), image::ExtendedColorType::Rgb8).unwrap();
    std::fs::write(path, buf).unwrap();
}

#[test]
fn jpeg_loads_upright_with_its_exif_orientation_and_bmp_tga_tiff_and_webp_load() {
    let d = tmp("jpeg");
    // 16×8, left half black, right half white
    let img = image::RgbImage::from_fn(16, 8, |x, _| if x < 8 { image::Rgb([0; 3]) } else { image::Rgb([255; 3]) });
    write_jpeg(&d.join("plain.jpg"), &img, None);
    write_jpeg(&d.join("rot90.jpg"), &img, Some(exif_orientation(6)));
    let (w, h, px) = load_rgb(&d.join("plain.jpg"), 1, false).unwrap();
    assert_eq!((w, h), (16, 8));
    assert!(px[0][0] < 0.05 && px[15][0] > 0.95);
    // orientation 6: shown turned 90° clockwise, so the black half is on top
    let (w, h, px) = load_rgb(&d.join("rot90.jpg"), 1, false).unwrap();
    assert_eq!((w, h), (8, 16));
    assert!(px[0][0] < 0.05 && px[(15 * 8) as usize][0] > 0.95, "{:?} {:?}", px[0], px[120]);
    // 16-bit grey PNG with alpha
    let grey = image::ImageBuffer::<image::LumaA<u16>, Vec<u16>>::from_pixel(4, 4, image::LumaA([32768, 65535]));
    grey.save(d.join("grey16.png")).unwrap();
    let (_, _, px) = load_rgb(&d.join("grey16.png"), 2, false).unwrap();
    assert!((px[0][0] - 0.5).abs() < 1e-3 && px[0][0] == px[0][2]);
    // BMP, TGA, TIFF and WebP, which COLMAP reads too
    for ext in ["bmp", "tga", "tif", "tiff", "webp"] {
        img.save(d.join(format!("plain.{ext}"))).unwrap();
        let (w, h, px) = load_rgb(&d.join(format!("plain.{ext}")), 1, false).unwrap();
        assert_eq!((w, h), (16, 8), "{ext}");
        assert!(px[0][0] == 0.0 && px[15][0] == 1.0, "{ext}");
    }
    // a 16-bit TIFF, as raw converters write: its full precision kept
    let deep = image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_pixel(4, 4, image::Rgb([1000, 32768, 65535]));
    deep.save(d.join("deep.tiff")).unwrap();
    let (_, _, px) = load_rgb(&d.join("deep.tiff"), 1, false).unwrap();
    assert!((px[0][0] - 1000.0 / 65535.0).abs() < 1e-6 && px[0][2] == 1.0, "{:?}", px[0]);
    // a file that is not an image is named
    std::fs::write(d.join("bad.jpg"), b"not a jpeg").unwrap();
    let e = load_rgb(&d.join("bad.jpg"), 1, false).unwrap_err().to_string();
    assert!(e.contains("bad.jpg") && e.contains("cannot read image"), "{e}");
}

/// An instant-ngp capture from the COLMAP one: transforms.json with the
/// OPENCV camera's intrinsics and distortion keys, two frames whose
/// images were deleted.
fn ngp_capture(d: &Path) {
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

#[test]
fn ngp_capture_skips_missing_frames_and_reads_its_lens() {
    let d = tmp("ngp-capture");
    ngp_capture(&d);
    let train = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    let test = load(&d, Split::Test, opts(Format::Ngp)).unwrap();
    // 5 frames listed, 2 images missing: 3 kept, every 4th held out (1)
    assert_eq!((train.views.len(), test.views.len()), (2, 1));
    assert!(train.notes.iter().any(|n| n.contains("2 of 5 frames skipped")), "{:?}", train.notes);
    assert!(train.views.iter().all(|v| matches!(v.lens, Lens::Opencv { .. })));
    let flat = load(&d, Split::Train, LoadOptions { lens: false, ..opts(Format::Auto) }).unwrap();
    assert!(flat.views.iter().all(|v| v.lens == Lens::Pinhole));
    // an unknown camera model is refused by name
    let t = std::fs::read_to_string(d.join("transforms.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
    v["camera_model"] = "EQUIRECTANGULAR".into();
    std::fs::write(d.join("transforms.json"), v.to_string()).unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("EQUIRECTANGULAR") && e.contains("not supported"), "{e}");
}

/// `d/transforms.json` edited by `f`.
fn edit_transforms(d: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let t = std::fs::read_to_string(d.join("transforms.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
    f(&mut v);
    std::fs::write(d.join("transforms.json"), v.to_string()).unwrap();
}

#[test]
fn ngp_capture_reads_paths_focal_keys_and_split_files_as_instant_ngp_does() {
    let d = tmp("ngp-variants");
    ngp_capture(&d);
    let base = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    let same = |other: &nerf_train::dataset::Dataset, what: &str| {
        assert_eq!(other.views.len(), base.views.len(), "{what}");
        for (u, v) in base.views.iter().zip(&other.views) {
            assert_eq!((u.camera, &u.rgb), (v.camera, &v.rgb), "{what}: {}", u.name);
        }
    };
    // file paths without their extension, and with Windows separators
    let orig = std::fs::read_to_string(d.join("transforms.json")).unwrap();
    edit_transforms(&d, |v| {
        for (i, f) in v["frames"].as_array_mut().unwrap().iter_mut().enumerate() {
            let p = f["file_path"].as_str().unwrap().to_string();
            f["file_path"] = if i % 2 == 0 { p.trim_end_matches(".jpg").into() } else { p.replace('/', "\\").into() };
        }
    });
    same(&load(&d, Split::Train, opts(Format::Auto)).unwrap(), "paths");
    // the focal length from fl_y alone, or from camera_angle_y (a square pixel)
    std::fs::write(d.join("transforms.json"), &orig).unwrap();
    let (fx, fy) = (base.views[0].camera.fx, base.views[0].camera.fy);
    edit_transforms(&d, |v| {
        v.as_object_mut().unwrap().remove("fl_x");
    });
    let fl_y = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert!(fl_y.views.iter().all(|v| v.camera.fx == fy && v.camera.fy == fy), "{fx} {fy}");
    edit_transforms(&d, |v| {
        v.as_object_mut().unwrap().remove("fl_y");
        v["camera_angle_y"] = (2.0 * (8.0 / fy as f64).atan()).into();
    });
    let angle_y = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert!(angle_y.views.iter().all(|v| (v.camera.fy - fy).abs() < 1e-4 && v.camera.fx == v.camera.fy));
    edit_transforms(&d, |v| {
        v.as_object_mut().unwrap().remove("camera_angle_y");
    });
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("transforms.json") && e.contains("no fl_x or fl_y"), "{e}");
    // nerfstudio's r⁸ term of a perspective lens is refused by name, not dropped
    std::fs::write(d.join("transforms.json"), &orig).unwrap();
    edit_transforms(&d, |v| v["k4"] = 0.01.into());
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("k4") && e.contains("not supported"), "{e}");
    // split into transforms_{train,test}.json with the capture's keys: an ngp capture, not Blender
    std::fs::write(d.join("transforms.json"), &orig).unwrap();
    std::fs::copy(d.join("transforms.json"), d.join("transforms_train.json")).unwrap();
    let mut test: serde_json::Value = serde_json::from_str(&orig).unwrap();
    let last = test["frames"].as_array().unwrap().last().unwrap().clone();
    test["frames"] = serde_json::json!([last]);
    std::fs::write(d.join("transforms_test.json"), test.to_string()).unwrap();
    assert_eq!(nerf_train::dataset::detect(&d).unwrap(), Format::Ngp);
    let split = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    // every frame of the training file whose image exists (3 of 5), each with its lens
    assert_eq!(split.views.len(), 3);
    assert!(split.views.iter().all(|v| matches!(v.lens, Lens::Opencv { .. })));
    // the test file's one photo is the training file's last: the same camera in the training split's frame
    let test = load(&d, Split::Test, opts(Format::Auto)).unwrap();
    assert_eq!(test.views.len(), 1);
    let same = split.views.iter().find(|v| v.name == test.views[0].name).expect("the photo in both files");
    assert_eq!(test.views[0].camera, same.camera);
    assert_eq!(test.scene, split.scene);
    // the same split files with a Blender camera_angle_x and a lens without distortion: a Blender split
    let mut blender: serde_json::Value = serde_json::from_str(&orig).unwrap();
    for k in ["k1", "k2", "p1", "p2"] {
        blender[k] = 0.0.into();
    }
    blender["camera_angle_x"] = 0.69.into();
    std::fs::write(d.join("transforms_train.json"), blender.to_string()).unwrap();
    assert_eq!(nerf_train::dataset::detect(&d).unwrap(), Format::Blender);
}

#[test]
fn nerfstudio_masks_leave_their_pixels_out_at_every_downscale() {
    let d = tmp("ngp-masks");
    ngp_capture(&d);
    // frames img_000, img_001, img_003 (two images missing); every 4th held out: img_000 is the test view
    std::fs::create_dir_all(d.join("masks")).unwrap();
    // the five left columns left out (0), the rest kept (any other value)
    let mask = image::GrayImage::from_fn(16, 16, |x, _| image::Luma([if x < 5 { 0 } else { 1 + x as u8 }]));
    mask.save(d.join("masks/img_000.png")).unwrap();
    edit_transforms(&d, |v| v["frames"][0]["mask_path"] = "masks/img_000.png".into());
    let full = load(&d, Split::Test, opts(Format::Auto)).unwrap();
    let m = &full.views[0].mask;
    assert_eq!(m.len(), 256);
    assert!(m.iter().enumerate().all(|(i, &k)| k == (i % 16 >= 5)));
    // at half size a pixel is kept only if all four photo pixels it averages are: columns 3.. (2 holds column 4)
    let half = load(&d, Split::Test, LoadOptions { downscale: 2, ..opts(Format::Auto) }).unwrap();
    assert!(half.views[0].mask.iter().enumerate().all(|(i, &k)| k == (i % 8 >= 3)));
    // resampled through the lens, the left-out columns stay out, the far side stays in
    let flat = load(&d, Split::Test, LoadOptions { undistort: true, ..opts(Format::Auto) }).unwrap();
    let m = &flat.views[0].mask;
    assert!(m.iter().enumerate().all(|(i, &k)| (i % 16 > 3 || !k) && (i % 16 < 8 || k)));
    // a resampled pixel is kept exactly when the lens imaged it (its source lies in the photo) and every
    // photo pixel it blends (weight above 10⁻⁴) is kept
    let (lens, c) = (full.views[0].lens, full.views[0].camera);
    let mut unimaged = 0;
    for (i, &k) in m.iter().enumerate() {
        let (x, y) = ((i % 16) as f64 + 0.5 - c.cx as f64, (i / 16) as f64 + 0.5 - c.cy as f64);
        let (xd, yd) = lens.distort(x / c.fx as f64, y / c.fy as f64);
        let (sx, sy) = (xd * c.fx as f64 + c.cx as f64, yd * c.fy as f64 + c.cy as f64);
        let imaged = (0.0..=16.0).contains(&sx) && (0.0..=16.0).contains(&sy);
        unimaged += !imaged as usize;
        let su = (sx - 0.5).clamp(0.0, 15.0);
        let (u0, a) = (su.floor() as usize, su.fract());
        let blended = [(u0, 1.0 - a), ((u0 + 1).min(15), a)];
        let kept = imaged && blended.iter().all(|&(u, w)| w < 1e-4 || u >= 5);
        assert_eq!(k, kept, "pixel {i}: source ({sx}, {sy})");
    }
    assert_eq!(unimaged, 0, "this lens images every pixel of the pinhole photo");
    // a pincushion lens leaves the pinhole photo's corners unimaged: they train on no photo's pixels
    let orig = std::fs::read_to_string(d.join("transforms.json")).unwrap();
    edit_transforms(&d, |v| v["k1"] = 0.4.into());
    let pin = load(&d, Split::Train, LoadOptions { undistort: true, ..opts(Format::Auto) }).unwrap();
    for v in &pin.views {
        assert!(!v.mask[0] && !v.mask[255] && v.mask[8 * 16 + 8], "{}", v.name);
    }
    std::fs::write(d.join("transforms.json"), orig).unwrap();
    // a held-out photo whose mask hides it whole is left out, and the split says so
    image::GrayImage::new(16, 16).save(d.join("masks/img_000.png")).unwrap();
    let e = load(&d, Split::Test, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("no images in the test split") && e.contains("all 1 of its photos hidden whole"), "{e}");
    // split files with Blender's camera_angle_x and masks load with their masks
    let mut t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("transforms.json")).unwrap()).unwrap();
    for k in ["k1", "k2", "p1", "p2"] {
        t[k] = 0.0.into();
    }
    t["camera_angle_x"] = 0.69.into();
    // the frames whose photo is there (the Blender loader reads every frame it lists)
    let there: Vec<serde_json::Value> = t["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| d.join(f["file_path"].as_str().unwrap()).is_file())
        .cloned()
        .collect();
    t["frames"] = there.into();
    mask.save(d.join("masks/img_000.png")).unwrap();
    std::fs::write(d.join("transforms_train.json"), t.to_string()).unwrap();
    assert_eq!(nerf_train::dataset::detect(&d).unwrap(), Format::Ngp);
    let split = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert_eq!(split.views.iter().filter(|v| !v.mask.is_empty()).count(), 1);
    let e = load(&d, Split::Train, opts(Format::Blender)).unwrap();
    assert!(e.notes.iter().any(|n| n.contains("the Blender loader does not apply")), "{:?}", e.notes);
    std::fs::remove_file(d.join("transforms_train.json")).unwrap();
    // the training views have no mask: every pixel kept
    let train = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert!(train.views.iter().all(|v| v.mask.is_empty()));
    // a mask of another size, or one that is not there, is an error naming it
    image::GrayImage::new(8, 16).save(d.join("masks/img_000.png")).unwrap();
    let e = load(&d, Split::Test, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("img_000.png") && e.contains("mask is 8x16 but its photo") && e.contains("is 16x16"), "{e}");
    std::fs::remove_file(d.join("masks/img_000.png")).unwrap();
    let e = load(&d, Split::Test, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("mask_path") && e.contains("img_000.png") && e.contains("not a file"), "{e}");
}

#[test]
fn colmap_captures_take_masks_from_a_masks_folder_named_as_colmap_or_nerfstudio_names_them() {
    let d = tmp("colmap-masks");
    write_colmap(&d, spec(), ColmapText::Binary, false).unwrap();
    std::fs::create_dir_all(d.join("masks")).unwrap();
    let top = |size: u32| image::GrayImage::from_fn(size, size, |_, y| image::Luma([if y < 4 { 0 } else { 255 }]));
    // COLMAP's naming (the image's name with .png added), then nerfstudio's (the extension replaced)
    top(16).save(d.join("masks/img_002.jpg.png")).unwrap();
    top(16).save(d.join("masks/img_006.png")).unwrap();
    let data = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    for v in &data.views {
        let masked = v.name == "img_002" || v.name == "img_006";
        let expect: Vec<bool> = if masked { (0..256).map(|i| i / 16 >= 4).collect() } else { Vec::new() };
        assert_eq!(v.mask, expect, "{}", v.name);
    }
    assert!(data.notes.iter().any(|n| n.contains("2 of the 10 registered photos have a mask")), "{:?}", data.notes);
    // a mask of another size is an error naming it
    top(8).save(d.join("masks/img_006.png")).unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("img_006.png") && e.contains("mask is 8x8 but its photo") && e.contains("is 16x16"), "{e}");
    // a masks/ folder none of whose files is named as a photo's mask is reported
    std::fs::remove_file(d.join("masks/img_006.png")).unwrap();
    std::fs::rename(d.join("masks/img_002.jpg.png"), d.join("masks/img_002_mask.png")).unwrap();
    let data = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert!(data.notes.iter().any(|n| n.contains("no masks applied")), "{:?}", data.notes);
    assert!(data.views.iter().all(|v| v.mask.is_empty()));
    // a photo with a mask under both names, and a masks that is a file: refused, not chosen between
    top(16).save(d.join("masks/img_004.jpg.png")).unwrap();
    top(16).save(d.join("masks/img_004.png")).unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("two masks for photo img_004.jpg: img_004.jpg.png and img_004.png"), "{e}");
    std::fs::remove_dir_all(d.join("masks")).unwrap();
    std::fs::write(d.join("masks"), b"").unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("masks") && e.contains("is not a folder"), "{e}");
}

#[test]
fn ngp_captures_take_photos_as_stored_whatever_their_exif_orientation() {
    let d = tmp("ngp-exif");
    ngp_capture(&d);
    let base = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    // every photo written again with the same pixels, without and with orientation 6 (shown turned 90°)
    let photos: Vec<(PathBuf, image::RgbImage)> = std::fs::read_dir(d.join("images"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| (p.clone(), image::open(&p).unwrap().to_rgb8()))
        .collect();
    photos.iter().for_each(|(p, img)| write_jpeg(p, img, None));
    let plain = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    photos.iter().for_each(|(p, img)| write_jpeg(p, img, Some(exif_orientation(6))));
    let turned = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert_eq!(turned.views.len(), base.views.len());
    for (u, v) in plain.views.iter().zip(&turned.views) {
        assert_eq!((u.camera, &u.rgb), (v.camera, &v.rgb), "{}", u.name);
    }
}

#[test]
fn training_on_a_capture_whose_rays_miss_the_scene_fails_at_once() {
    let root = tmp("miss");
    let d = root.join("capture");
    ngp_capture(&d);
    let t = std::fs::read_to_string(d.join("transforms.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
    // a box far behind every camera
    v["aabb"] = serde_json::json!([[100.0, 100.0, 100.0], [101.0, 101.0, 101.0]]);
    std::fs::write(d.join("transforms.json"), v.to_string()).unwrap();
    let out = root.join("run");
    let start = std::time::Instant::now();
    let o = nerf(&["train", "--data", s(&d), "--iters", "5", "--out", s(&out)]);
    assert!(start.elapsed().as_secs() < 30, "took {:?}", start.elapsed());
    assert!(!o.status.success());
    // the warning about the missing frames, then the error
    let stderr = String::from_utf8_lossy(&o.stderr);
    let e = stderr.lines().last().unwrap_or_default();
    assert!(e.contains("meet the scene") && e.contains("aabb"), "{e}");
    assert!(!out.join("model.nerf").exists() && !out.join("checkpoint.bin").exists());
}

/// Writes the built-in scene (16 px, `views` training views) into
/// `root/scene` and trains `iters` steps on its capture `capture` (`colmap`,
/// `room`, …) with `flags` into `root/run`; returns the capture's folder
/// and the model.
fn trained_capture(root: &Path, views: &str, capture: &str, iters: &str, flags: &[&str]) -> (PathBuf, PathBuf) {
    let scene = root.join("scene");
    support::cli::ok(&["scene", "--out", s(&scene), "--size", "16", "--train", views]);
    let (data, run) = (scene.join(capture), root.join("run"));
    let mut args = vec!["train", "--data", s(&data), "--iters", iters, "--out", s(&run), "--val-views", "0"];
    args.extend_from_slice(flags);
    support::cli::ok(&args);
    (data, run.join("model.nerf"))
}

/// The JSON a `nerf` command prints.
fn json(args: &[&str]) -> serde_json::Value {
    serde_json::from_str(&support::cli::ok(args)).unwrap()
}

#[test]
fn videos_follow_the_capture_trajectory_and_nerfstudio_camera_paths() {
    let root = tmp("paths");
    let (data, model) = trained_capture(&root, "6", "colmap", "2", &[]);
    let scene = root.join("scene");
    let a = root.join("a");
    support::cli::ok(&["render", s(&model), "--data", s(&data), "--trajectory", "3", "--size", "20", "--out", s(&a)]);
    for f in ["frame_000.png", "frame_002_depth.png", "frame_001_depth_preview.png", "frame_000_opacity.png"] {
        assert!(a.join(f).is_file(), "{f}");
    }
    assert!(a.join("path.gif").is_file() && a.join("depth.json").is_file());
    // the path written beside the frames renders the same frames again
    let b = root.join("b");
    support::cli::ok(&[
        "render",
        s(&model),
        "--camera-path",
        s(&a.join("camera_path.json")),
        "--size",
        "20",
        "--out",
        s(&b),
    ]);
    for k in 0..3 {
        let f = format!("frame_{k:03}.png");
        assert_eq!(std::fs::read(a.join(&f)).unwrap(), std::fs::read(b.join(&f)).unwrap(), "{f}");
    }
    // the same cameras as keyframes alone: 4 frames interpolated, the first at keyframe 0
    let path: serde_json::Value = serde_json::from_slice(&std::fs::read(a.join("camera_path.json")).unwrap()).unwrap();
    let keys: Vec<serde_json::Value> = path["camera_path"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| serde_json::json!({ "matrix": c["camera_to_world"], "fov": c["fov"], "aspect": c["aspect"] }))
        .collect();
    let keyed = serde_json::json!({ "keyframes": keys, "fps": 4, "seconds": 1, "smoothness_value": 0.5 });
    let kf = root.join("keyframes.json");
    std::fs::write(&kf, keyed.to_string()).unwrap();
    let c = root.join("c");
    support::cli::ok(&["render", s(&model), "--camera-path", s(&kf), "--size", "20", "--out", s(&c)]);
    assert!(c.join("frame_003.png").is_file() && !c.join("frame_004.png").exists());
    let (x, y) = (image::open(a.join("frame_000.png")).unwrap(), image::open(c.join("frame_000.png")).unwrap());
    let diff: u32 = x.as_bytes().iter().zip(y.as_bytes()).map(|(p, q)| p.abs_diff(*q) as u32).max().unwrap();
    assert!(x.as_bytes().len() == y.as_bytes().len() && diff <= 2, "keyframe 0 renders as camera 0: {diff}");
    // views loaded in another frame than the model's are refused
    let o = nerf(&["eval", s(&model), "--data", s(&data), "--split", "val", "--scene", "forward"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("forward-facing") && e.contains("--scene"), "{e}");
    let depth = image::open(a.join("frame_000_depth.png")).unwrap();
    assert_eq!(depth.color(), image::ColorType::L16);
    // a forward-facing model's orbit is a circle in front of the capture: every ray meets the scene
    let llff = load(&scene.join("llff"), Split::Train, opts(Format::Auto)).unwrap();
    let spiral = Orbit::new(&llff.scene, None);
    let cam = spiral.camera(0.3, 8, 6).unwrap();
    for (x, y) in [(0, 0), (7, 5), (4, 3)] {
        let (o, d) = cam.ray(x, y);
        assert!(nerf_infer::Ray::new(&llff.scene, o, d).is_some(), "({x},{y})");
    }
}

#[test]
fn a_model_records_how_its_capture_was_split_and_eval_reuses_it() {
    let root = tmp("split");
    let flags = ["--llffhold", "3", "--scene", "object", "--ignore-distortion"];
    let (data, model) = trained_capture(&root, "7", "colmap", "2", &flags);
    let info = json(&["info", s(&model), "--json"]);
    // an object scene has no proposal grid: the version before it
    let version = nerf_infer::format::FORMAT_VERSION_NO_PROPOSAL;
    assert_eq!(info["format_version"], version, "a capture record and a fitted orbit");
    let c = &info["capture"];
    assert_eq!(
        (c["holdout"].as_u64(), c["framing"].as_str(), c["lens"].as_bool()),
        (Some(3), Some("Object"), Some(false))
    );
    // eval without the flags scores the views the model was trained without
    let held_out = load(&data, Split::Val, LoadOptions { holdout: 3, lens: false, ..opts(Format::Auto) }).unwrap();
    let default_split = load(&data, Split::Val, opts(Format::Auto)).unwrap();
    assert_ne!(held_out.views.len(), default_split.views.len());
    let report = json(&["eval", s(&model), "--data", s(&data), "--split", "val"]);
    let names: Vec<&str> = report["views"].as_array().unwrap().iter().map(|v| v["name"].as_str().unwrap()).collect();
    let expected: Vec<&str> = held_out.views.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, expected);
    // another hold-out would score training views: refused, naming the model's
    let o = nerf(&["eval", s(&model), "--data", s(&data), "--llffhold", "4"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("--llffhold 3"), "{e}");
    // a capture with other views than the model's: evaluated, with a warning
    let other = root.join("other");
    support::cli::ok(&["scene", "--out", s(&other), "--size", "16", "--train", "9"]);
    let o = nerf(&["eval", s(&model), "--data", s(&other.join("colmap"))]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && e.contains("warning") && e.contains("not the model's"), "{e}");
}

#[test]
fn a_capture_all_around_trains_unbounded_and_both_paths_render_it() {
    let root = tmp("unbounded");
    let (data, model) = trained_capture(&root, "6", "room", "3", &[]);
    let run = model.parent().unwrap().to_path_buf();
    let info = json(&["info", s(&model), "--json"]);
    assert_eq!(info["format_version"], nerf_infer::format::FORMAT_VERSION, "unbounded, with a proposal grid");
    let lin = info["scene"]["unbounded"]["linear_until"].as_f64().expect("an unbounded scene");
    let far = info["scene"]["far"].as_f64().unwrap();
    assert!(lin > 1.0 && far >= 100.0 * lin, "linear until {lin}, far {far}");
    // the orbit is fitted to the training cameras: up perpendicular to their right axes (the scene's
    // cameras do not roll), within their fields of view, about the median camera's distance (1 in
    // fitted units) and a height above the centre (they look down at it)
    let o = &info["orbit"];
    let num = |k: &str| o[k].as_f64().unwrap();
    let v = |k: &str| -> Vec<f64> { o[k].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
    let (centre, up) = (v("centre"), v("up"));
    let train = load(&data, Split::Train, LoadOptions { holdout: 8, ..opts(Format::Auto) }).unwrap();
    let up3 = glam::Vec3::new(up[0] as f32, up[1] as f32, up[2] as f32);
    for v in &train.views {
        let (right, cam_up) = (v.camera.rotation.x_axis, v.camera.rotation.y_axis);
        assert!(up3.dot(right).abs() < 1e-4 && up3.dot(cam_up) > 0.0, "{up:?} against {}", v.name);
    }
    let fov = |c: &nerf_infer::Camera| 2.0 * (0.5 * c.width as f64 / c.fx as f64).atan();
    let (lo, hi) =
        train.views.iter().map(|v| fov(&v.camera)).fold((f64::MAX, 0.0f64), |(a, b), f| (a.min(f), b.max(f)));
    assert!(num("fov_x") >= lo - 1e-6 && num("fov_x") <= hi + 1e-6, "{} outside {lo}..{hi}", num("fov_x"));
    let (radius, height) = (num("radius"), num("height"));
    assert!((radius.hypot(height) - 1.0).abs() < 0.2 && height > 0.1, "radius {radius}, height {height}");
    // and the video's cameras follow it
    let out = root.join("orbit-fitted");
    support::cli::ok(&["render", s(&model), "--orbit", "3", "--size", "8", "--out", s(&out)]);
    let path: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("camera_path.json")).unwrap()).unwrap();
    for c in path["camera_path"].as_array().unwrap() {
        let m: Vec<f64> = c["camera_to_world"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let rel: Vec<f64> = (0..3).map(|r| m[4 * r + 3] - centre[r]).collect();
        let h: f64 = (0..3).map(|r| rel[r] * up[r]).sum();
        let d = rel.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!((h - height).abs() < 1e-3 && (d - radius.hypot(height)).abs() < 1e-3, "height {h}, distance {d}");
    }
    let int8 = run.join("int8.nerf");
    support::cli::ok(&["export", s(&model), "--bits", "8", "--out", s(&int8)]);
    let mut psnr = Vec::new();
    for m in [&model, &int8] {
        let out = root.join(format!("orbit-{}", m.file_stem().unwrap().to_string_lossy()));
        support::cli::ok(&["render", s(m), "--orbit", "2", "--size", "12", "--out", s(&out)]);
        assert!(out.join("orbit.gif").is_file());
        let report = json(&["eval", s(m), "--data", s(&data), "--split", "val"]);
        psnr.push(report["psnr"].as_f64().unwrap());
    }
    // the int8 path renders what the f32 one does (int8 stays within 0.1 dB on trained models)
    assert!(psnr[0].is_finite() && (psnr[0] - psnr[1]).abs() < 0.25, "f32 {} dB, int8 {} dB", psnr[0], psnr[1]);
}

#[test]
fn llff_captures_are_fitted_as_colmap_ones() {
    use nerf_train::dataset::colmap::colmap_views;
    use nerf_train::dataset::synthetic::{write_llff, write_llff_room};
    use nerf_train::dataset::write_poses_bounds;
    let d = tmp("llff-fit");
    // an inward 360° capture in LLFF's layout becomes unbounded, as its COLMAP twin
    write_llff_room(&d.join("room_llff"), spec()).unwrap();
    let room = load(&d.join("room_llff"), Split::Train, opts(Format::Auto)).unwrap();
    assert!(room.scene.ndc.is_none() && room.scene.unbounded.is_some(), "{:?}", room.scene);
    assert_eq!(room.capture.as_ref().unwrap().framing, nerf_infer::format::Framing::Unbounded);
    assert!(room.ray_hit_fraction() > 0.99);
    // a forward-facing one stays in NDC, and --scene applies to the layout
    write_llff(&d.join("forward"), spec()).unwrap();
    let fwd = load(&d.join("forward"), Split::Train, opts(Format::Auto)).unwrap();
    assert!(fwd.scene.ndc.is_some() && fwd.scene.unbounded.is_none());
    let forced = LoadOptions { scene: SceneKind::Forward, ..opts(Format::Auto) };
    assert!(load(&d.join("room_llff"), Split::Train, forced).unwrap().scene.ndc.is_some());
    let object = LoadOptions { scene: SceneKind::Object, ..opts(Format::Auto) };
    let object = load(&d.join("room_llff"), Split::Train, object).unwrap().scene;
    assert!(object.ndc.is_none() && object.unbounded.is_none());
    // the COLMAP room written as LLFF (imgs2poses' bounds from the sparse points) gives the same cameras in the
    // same fitted frame, and a near plane within a factor of two of the COLMAP fit's
    write_colmap(&d.join("room"), spec(), ColmapText::Binary, true).unwrap();
    let (views, points) = colmap_views(&d.join("room"), &d.join("room/sparse/0")).unwrap();
    let conv = d.join("room_as_llff");
    std::fs::create_dir_all(conv.join("images")).unwrap();
    for v in &views {
        std::fs::copy(&v.image, conv.join("images").join(v.image.file_name().unwrap())).unwrap();
    }
    write_poses_bounds(&conv, &views, &points).unwrap();
    let a = load(&d.join("room"), Split::Test, opts(Format::Auto)).unwrap();
    let b = load(&conv, Split::Test, opts(Format::Auto)).unwrap();
    assert_eq!(a.views.len(), b.views.len());
    for (u, v) in a.views.iter().zip(&b.views) {
        assert_eq!(u.name, v.name);
        let (p, q) = (u.camera.position, v.camera.position);
        assert!((p - q).length() < 1e-4, "{}: {p} against {q}", u.name);
    }
    assert!(b.scene.unbounded.is_some());
    let ratio = b.scene.near / a.scene.near;
    assert!((0.5..2.0).contains(&ratio), "near {} against {}", b.scene.near, a.scene.near);
}

#[test]
fn llff_captures_read_the_downscaled_copies_they_ship() {
    use nerf_train::dataset::synthetic::write_llff_room;
    let d = tmp("llff-images-n");
    write_llff_room(&d, spec()).unwrap();
    let half = LoadOptions { downscale: 2, ..opts(Format::Auto) };
    let from_full = load(&d, Split::Train, half).unwrap();
    // images_2: each photo at half size, grey, so the photos read show where they came from
    std::fs::create_dir_all(d.join("images_2")).unwrap();
    for e in std::fs::read_dir(d.join("images")).unwrap() {
        let p = e.unwrap().path();
        let (w, h) = image::image_dimensions(&p).unwrap();
        write_jpeg(
            &d.join("images_2").join(p.file_name().unwrap()),
            &image::RgbImage::from_pixel(w / 2, h / 2, image::Rgb([128; 3])),
            None,
        );
    }
    let from_copies = load(&d, Split::Train, half).unwrap();
    assert_eq!(from_copies.views.len(), from_full.views.len());
    for (u, v) in from_full.views.iter().zip(&from_copies.views) {
        assert_eq!(u.camera, v.camera, "{}", u.name);
        assert!(v.rgb.iter().all(|c| (c[0] - 0.5).abs() < 0.02), "{}: read from images_2", v.name);
        assert!(u.rgb != v.rgb);
    }
    // at downscale 4 without images_4: images/ is read
    let quarter = load(&d, Split::Train, LoadOptions { downscale: 4, ..opts(Format::Auto) }).unwrap();
    assert!(quarter.views.iter().all(|v| v.rgb.iter().any(|c| (c[0] - 0.5).abs() > 0.05)));
    // with images/ gone, the error names the copy that can be read instead
    std::fs::rename(d.join("images"), d.join("originals")).unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("images_2/ (--downscale 2) can be read instead"), "{e}");
    std::fs::rename(d.join("originals"), d.join("images")).unwrap();
    // a shipped copy missing photos is passed over
    std::fs::remove_file(
        d.join("images_2").join(std::fs::read_dir(d.join("images_2")).unwrap().next().unwrap().unwrap().file_name()),
    )
    .unwrap();
    let partial = load(&d, Split::Train, half).unwrap();
    for (u, v) in from_full.views.iter().zip(&partial.views) {
        assert_eq!(&u.rgb, &v.rgb, "{}", u.name);
    }
    // a copy whose photos are renamed (nerf_llff_data's image000.png, …) is passed over while images/ is
    // there: the views keep images/'s names, which a model records
    std::fs::remove_dir_all(d.join("images_2")).unwrap();
    std::fs::create_dir_all(d.join("images_2")).unwrap();
    for (i, v) in from_full.views.iter().enumerate() {
        let (w, h) = (v.camera.width, v.camera.height);
        write_jpeg(
            &d.join(format!("images_2/image{i:03}.jpg")),
            &image::RgbImage::from_pixel(w, h, image::Rgb([128; 3])),
            None,
        );
    }
    let n = std::fs::read_dir(d.join("images")).unwrap().count();
    for i in from_full.views.len()..n {
        std::fs::copy(d.join("images_2/image000.jpg"), d.join(format!("images_2/image{i:03}.jpg"))).unwrap();
    }
    let renamed = load(&d, Split::Train, half).unwrap();
    for (u, v) in from_full.views.iter().zip(&renamed.views) {
        assert_eq!((&u.name, &u.rgb), (&v.name, &v.rgb));
    }
}

#[test]
fn a_nerfstudio_capture_with_its_sparse_points_is_fitted_as_its_colmap_twin() {
    use nerf_train::dataset::colmap::colmap_views;
    let d = tmp("ngp-ply");
    // 32-pixel photos: enough sparse points (one per 8×8 pixels the object covers) for the fit
    write_colmap(&d, SceneSpec { size: 32, ..spec() }, ColmapText::Binary, false).unwrap();
    let (views, points) = colmap_views(&d, &d.join("sparse/0")).unwrap();
    assert!(points.len() >= 20, "{} sparse points: too few for the fit to use", points.len());
    // nerfstudio's layout of the same capture: the poses and the sparse points in one frame
    let frames: Vec<serde_json::Value> = views
        .iter()
        .map(|v| {
            let (r, p) = v.pose;
            let m: Vec<Vec<f64>> = (0..3).map(|i| vec![r.x_axis[i], r.y_axis[i], r.z_axis[i], p[i]]).collect();
            let (k, t) = match v.lens {
                Lens::Opencv { k, p } => (k, p),
                Lens::Pinhole => ([0.0; 6], [0.0; 2]),
                other => panic!("{other:?}"),
            };
            let c = &v.intrinsics;
            serde_json::json!({
                "file_path": format!("images/{}", v.image.file_name().unwrap().to_string_lossy()),
                "transform_matrix": m, "w": c.size[0], "h": c.size[1], "fl_x": c.focal[0], "fl_y": c.focal[1],
                "cx": c.centre[0], "cy": c.centre[1], "k1": k[0], "k2": k[1], "p1": t[0], "p2": t[1],
            })
        })
        .collect();
    let mut ply = format!("ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
                           property float z\nproperty uint8 red\nproperty uint8 green\nproperty uint8 blue\nend_header\n", points.len());
    points.iter().for_each(|q| ply.push_str(&format!("{} {} {} 128 128 128\n", q.x, q.y, q.z)));
    std::fs::write(d.join("sparse_pc.ply"), ply).unwrap();
    let t = serde_json::json!({ "frames": frames, "ply_file_path": "sparse_pc.ply" });
    std::fs::write(d.join("transforms.json"), t.to_string()).unwrap();
    // the object's box comes from the sparse points
    let object = |format| LoadOptions { scene: SceneKind::Object, ..opts(format) };
    let colmap = load(&d, Split::Test, object(Format::Colmap)).unwrap();
    let ngp = load(&d, Split::Test, object(Format::Ngp)).unwrap();
    assert_eq!(ngp.views.len(), colmap.views.len());
    for (a, b) in [(ngp.scene.near, colmap.scene.near), (ngp.scene.far, colmap.scene.far)]
        .into_iter()
        .chain((0..3).map(|i| (ngp.scene.bounds_max[i], colmap.scene.bounds_max[i])))
    {
        assert!((a - b).abs() < 1e-4 * b.abs().max(1.0), "{:?} against {:?}", ngp.scene, colmap.scene);
    }
    for (u, v) in ngp.views.iter().zip(&colmap.views) {
        assert!((u.camera.position - v.camera.position).length() < 1e-4, "{}", u.name);
    }
    // without its points the fit has the cameras alone: other bounds
    let t = serde_json::json!({ "frames": t["frames"] });
    std::fs::write(d.join("transforms.json"), t.to_string()).unwrap();
    let alone = load(&d, Split::Test, object(Format::Ngp)).unwrap();
    let moved = (0..3).map(|i| (alone.scene.bounds_min[i] - colmap.scene.bounds_min[i]).abs()).fold(0.0, f32::max);
    assert!(moved > 1e-2, "{:?} against {:?}", alone.scene, colmap.scene);
}

#[test]
fn of_several_reconstructions_the_one_registering_the_most_images_loads() {
    use nerf_train::dataset::colmap_io::{read_model, write_model_bin};
    let d = tmp("colmap-models");
    write_colmap(&d, spec(), ColmapText::Binary, true).unwrap();
    // COLMAP's mapper numbers its models in no order of size: sparse/0 registers 3 of the 10 photos, sparse/1 all
    let full = read_model(&d.join("sparse/0")).unwrap();
    std::fs::create_dir_all(d.join("sparse/1")).unwrap();
    write_model_bin(&d.join("sparse/1"), &full).unwrap();
    let mut part = full.clone();
    part.images.truncate(3);
    write_model_bin(&d.join("sparse/0"), &part).unwrap();
    let all = |o: LoadOptions| {
        let (a, b) = (load(&d, Split::Train, o).unwrap(), load(&d, Split::Test, o).unwrap());
        (a.views.len() + b.views.len(), a.notes)
    };
    let (n, notes) = all(opts(Format::Auto));
    assert_eq!(n, 10);
    let note = notes.iter().find(|n| n.contains("sparse/1")).expect("the choice is reported");
    assert!(note.contains("(10; sparse/0: 3)") && note.contains("--sparse-model"), "{note}");
    assert_eq!(all(LoadOptions { sparse_model: Some(0), ..opts(Format::Auto) }).0, 3);
    let e = load(&d, Split::Train, LoadOptions { sparse_model: Some(5), ..opts(Format::Auto) }).unwrap_err();
    let e = e.to_string();
    assert!(e.contains("sparse/5") && e.contains("sparse/0, sparse/1"), "{e}");
    // only a sparse/1 (sparse/0 deleted) is still a COLMAP capture
    std::fs::remove_dir_all(d.join("sparse/0")).unwrap();
    assert_eq!(all(opts(Format::Auto)).0, 10);
}
