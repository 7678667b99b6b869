//! Captures trained and rendered on data the tests make: videos along
//! the capture's trajectory, the split a model records, an all-around
//! capture trained unbounded, and one capture fitted alike in its COLMAP,
//! LLFF and nerfstudio layouts.

mod support;

use nerf_infer::Orbit;
use nerf_train::dataset::synthetic::{write_colmap, ColmapText, SceneSpec};
use nerf_train::dataset::{load, Format, LoadOptions, SceneKind, Split};
use std::path::{Path, PathBuf};
use support::captures::*;
use support::cli::{nerf, s, tmp};

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
    use nerf_train::dataset::write_transforms;
    let d = tmp("ngp-ply");
    // 32-pixel photos: enough sparse points (one per 8×8 pixels the object covers) for the fit
    write_colmap(&d, SceneSpec { size: 32, ..spec() }, ColmapText::Binary, false).unwrap();
    let (views, points) = colmap_views(&d, &d.join("sparse/0")).unwrap();
    assert!(points.len() >= 20, "{} sparse points: too few for the fit to use", points.len());
    // nerfstudio's layout of the same capture: the poses and the sparse points in one frame
    write_transforms(&d, &views, Some(&points)).unwrap();
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
    let with_points = load(&d, Split::Train, object(Format::Ngp)).unwrap();
    assert!(!with_points.notes.iter().any(|n| n.contains("no sparse points")), "{:?}", with_points.notes);
    // without its points the fit has the cameras alone: other bounds, and a note says what it took instead
    write_transforms(&d, &views, None).unwrap();
    let alone = load(&d, Split::Test, object(Format::Ngp)).unwrap();
    let trained = load(&d, Split::Train, object(Format::Ngp)).unwrap();
    let said = trained.notes.iter().find(|n| n.contains("no sparse points")).expect("a note on the missing points");
    assert!(said.contains("transforms.json") && said.contains("the cameras alone") && said.contains("±0.5"), "{said}");
    // said once, when the training split loads
    assert!(!alone.notes.iter().any(|n| n.contains("no sparse points")), "{:?}", alone.notes);
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
