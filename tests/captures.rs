//! Real-capture inputs on data the tests make: COLMAP models (binary and
//! text, several cameras, lens distortion, unregistered images, refused
//! camera models), JPEG with EXIF orientation, instant-ngp files with
//! missing frames and distortion keys, the fitted scene, and captures
//! whose rays miss the scene. Masks are in `capture_masks.rs`; captures
//! trained, rendered and fitted across layouts in `capture_training.rs`.

mod support;

use nerf_train::dataset::synthetic::{write_colmap, ColmapText, SceneSpec};
use nerf_train::dataset::{load, load_rgb, Format, Lens, LoadOptions, SceneKind, Split};
use std::path::PathBuf;
use support::captures::*;
use support::cli::{nerf, s, tmp};

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

#[test]
fn photos_taken_at_another_exposure_are_noted_with_the_per_photo_correction() {
    let d = tmp("exposure");
    write_colmap(&d, SceneSpec { size: 64, train: 12, val: 0, test: 0 }, ColmapText::Binary, false).unwrap();
    let said = || {
        let data = load(&d, Split::Train, opts(Format::Colmap)).unwrap();
        data.notes.into_iter().find(|n| n.contains("exposure"))
    };
    // rendered photos: one exposure
    assert_eq!(said(), None);
    // every third photo half as bright
    for k in (0..12).step_by(3) {
        let path = d.join(format!("images/img_{k:03}.jpg"));
        let mut img = image::open(&path).unwrap().to_rgb8();
        img.pixels_mut().for_each(|p| p.0.iter_mut().for_each(|c| *c /= 2));
        img.save(&path).unwrap();
    }
    let note = said().expect("a note on the photos' exposure");
    assert!(note.contains("×0.5") && note.contains("appearance"), "{note}");
}
