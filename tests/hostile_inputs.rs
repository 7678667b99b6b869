//! Hostile inputs of the capture and path surfaces: a photo whose header
//! claims an absurd size, files that never end (FIFOs, devices), outputs
//! that would replace the file being read, captures that contradict
//! themselves, camera paths with bad fields, a checkpoint given as a
//! model. Each ends in one line naming the file and the field, and
//! nothing of the user's is changed.

mod support;

use nerf_train::dataset::colmap_io::{read_model, write_model_bin};
use nerf_train::dataset::synthetic::{write_colmap, ColmapText, SceneSpec};
use nerf_train::dataset::{load, load_rgb, LoadOptions, Split};
use std::path::Path;
use support::cli::{fails, ok, s, tmp};

fn spec() -> SceneSpec {
    SceneSpec { size: 16, train: 8, val: 2, test: 0 }
}

fn model_file() -> String {
    format!("{}/models/scene.nerf", env!("CARGO_MANIFEST_DIR"))
}

/// A baseline JPEG of `w`×`h` pixels whose frame header (SOF0) then says
/// `claim`×`claim`: as a failing card's few flipped bytes leave it.
fn jpeg_claiming(path: &Path, w: u32, h: u32, claim: u16) {
    let img = image::RgbImage::from_pixel(w, h, image::Rgb([90, 120, 200]));
    let mut buf = std::io::Cursor::new(Vec::new());
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut buf, 90).encode_image(&img).unwrap();
    let mut b = buf.into_inner();
    let sof = b.windows(2).position(|m| m == [0xFF, 0xC0]).expect("a SOF0 marker");
    // marker, length (2), precision (1), height (2), width (2)
    b[sof + 5..sof + 7].copy_from_slice(&claim.to_be_bytes());
    b[sof + 7..sof + 9].copy_from_slice(&claim.to_be_bytes());
    std::fs::write(path, b).unwrap();
}

#[test]
fn a_photo_whose_header_claims_an_absurd_size_is_refused_before_decoding() {
    let d = tmp("huge-jpeg");
    let p = d.join("huge.jpg");
    jpeg_claiming(&p, 16, 16, 60000);
    let e = load_rgb(&p, 1, false).unwrap_err().to_string();
    assert!(e.contains("huge.jpg") && e.contains("60000"), "{e}");
    // the same in a capture: named, not a panic or an abort
    write_colmap(&d.join("cap"), spec(), ColmapText::Binary, false).unwrap();
    jpeg_claiming(&d.join("cap/images/img_002.jpg"), 16, 16, 60000);
    let e = load(&d.join("cap"), Split::Train, LoadOptions { holdout: 4, ..Default::default() }).unwrap_err();
    assert!(e.to_string().contains("img_002.jpg"), "{e}");
    let run = d.join("run");
    let e = fails(&["train", "--data", s(&d.join("cap")), "--iters", "1", "--out", s(&run)]);
    assert!(e.contains("img_002.jpg") && e.contains("60000"), "{e}");
}

#[test]
fn files_that_never_end_are_refused_not_read() {
    let d = tmp("endless");
    let fifo = d.join("path.json");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: mkfifo on a NUL-terminated path this test owns.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let out = d.join("out");
    let m = model_file();
    for path in [s(&fifo), "/dev/zero"] {
        let e = fails(&["render", &m, "--camera-path", path, "--size", "8", "--out", s(&out)]);
        assert!(e.contains(path) && e.contains("not a regular file"), "{e}");
        let e = fails(&["info", path]);
        assert!(e.contains(path) && e.contains("not a regular file"), "{e}");
    }
    let e = fails(&["train", "--data", s(&d), "--iters", "1", "--config", s(&fifo), "--out", s(&out)]);
    assert!(e.contains("--config") && e.contains("not a regular file"), "{e}");
}

#[test]
fn a_render_never_replaces_the_camera_path_it_reads() {
    let d = tmp("camera-path-out");
    let m = model_file();
    ok(&["render", &m, "--orbit", "3", "--size", "8", "--out", s(&d)]);
    let path = d.join("camera_path.json");
    let before = std::fs::read(&path).unwrap();
    let e = fails(&["render", &m, "--camera-path", s(&path), "--size", "8", "--out", s(&d)]);
    assert!(e.contains("--camera-path") && e.contains("camera_path.json"), "{e}");
    assert_eq!(std::fs::read(&path).unwrap(), before);
    // into another folder it renders
    ok(&["render", &m, "--camera-path", s(&path), "--size", "8", "--out", s(&d.join("again"))]);
}

#[test]
fn a_checkpoint_given_as_a_model_is_named_as_one() {
    let d = tmp("ckpt-as-model");
    let ck = d.join("checkpoint.bin");
    std::fs::write(&ck, b"NERFCKPT\x0b\x00 and the rest of a run").unwrap();
    let site = d.join("site");
    for cmd in ["info", "web"] {
        let mut args = vec![cmd, s(&ck)];
        if cmd == "web" {
            args.extend(["--out", s(&site)]);
        }
        let e = fails(&args);
        assert!(e.contains("checkpoint") && e.contains("model.nerf") && !e.contains("19267"), "{e}");
    }
}

#[test]
fn captures_that_contradict_themselves_are_refused_by_name() {
    let d = tmp("contradictions");
    write_colmap(&d, spec(), ColmapText::Binary, false).unwrap();
    let model = d.join("sparse/0");
    let good = read_model(&model).unwrap();
    let opts = LoadOptions { holdout: 4, ..Default::default() };
    // one photo registered twice with two poses
    let mut twice = good.clone();
    let mut dup = twice.images[3].clone();
    dup.id = 99;
    dup.tvec[0] += 0.5;
    twice.images.push(dup);
    write_model_bin(&model, &twice).unwrap();
    let e = load(&d, Split::Train, opts).unwrap_err().to_string();
    assert!(e.contains("img_003.jpg") && e.contains("99") && e.contains("two poses"), "{e}");
    // a principal point far outside the photo
    let mut off = good.clone();
    off.cameras[1].params[2] = 5000.0;
    write_model_bin(&model, &off).unwrap();
    let e = load(&d, Split::Train, opts).unwrap_err().to_string();
    assert!(e.contains("principal point") && e.contains("5000"), "{e}");
    // one registered photo: the split is empty, and the message says why
    let mut one = good.clone();
    one.images.truncate(1);
    write_model_bin(&model, &one).unwrap();
    let e = load(&d, Split::Train, opts).unwrap_err().to_string();
    assert!(e.contains("1 registered photos") && e.contains("at least two"), "{e}");
    write_model_bin(&model, &good).unwrap();
    assert!(load(&d, Split::Train, opts).is_ok());
}

#[test]
fn camera_path_fields_are_checked_one_by_one() {
    let d = tmp("camera-path-fields");
    let m = model_file();
    let eye = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 4.0], [0.0, 0.0, 0.0, 1.0]];
    let flat: Vec<f64> = eye.iter().flatten().copied().collect();
    let cam = |extra: serde_json::Value| {
        let mut c = serde_json::json!({ "camera_to_world": flat, "fov": 40.0, "aspect": 1.0 });
        c.as_object_mut().unwrap().extend(extra.as_object().unwrap().clone());
        c.as_object_mut().unwrap().retain(|_, v| !v.is_null());
        serde_json::json!({ "camera_path": [c] })
    };
    let key = |extra: serde_json::Value| {
        let mut v = serde_json::json!({ "keyframes": [{ "matrix": flat, "fov": 40.0, "aspect": 1.0 }] });
        v.as_object_mut().unwrap().extend(extra.as_object().unwrap().clone());
        v
    };
    let cases = [
        (cam(serde_json::json!({ "fov": 0 })), "fov 0"),
        (cam(serde_json::json!({ "fov": -30 })), "fov -30"),
        (cam(serde_json::json!({ "fov": 180 })), "fov 180"),
        (cam(serde_json::json!({ "fov": 1e9 })), "fov 1000000000"),
        (cam(serde_json::json!({ "fov": "wide" })), "fov is not a number"),
        (cam(serde_json::json!({ "aspect": 0 })), "aspect 0"),
        (cam(serde_json::json!({ "aspect": null })), "aspect is missing"),
        (cam(serde_json::json!({ "camera_to_world": null })), "matrix is missing"),
        (key(serde_json::json!({ "seconds": 2 })), "without fps"),
        (key(serde_json::json!({ "fps": -24, "seconds": -2 })), "must both be positive"),
        (serde_json::json!({ "camera_path": [], "keyframes": [] }), "lists are empty"),
        (serde_json::json!([1, 2]), "expected a JSON object"),
    ];
    for (i, (json, needle)) in cases.iter().enumerate() {
        let p = d.join(format!("path{i}.json"));
        std::fs::write(&p, json.to_string()).unwrap();
        let e = fails(&["render", &m, "--camera-path", s(&p), "--size", "8", "--out", s(&d.join("out"))]);
        assert!(e.contains(&format!("path{i}.json")) && e.contains(needle), "case {i}: {needle:?} not in {e}");
    }
    assert!(!d.join("out").exists(), "no frame rendered from a bad path");
}

#[test]
fn fit_never_writes_over_a_training_run() {
    let d = tmp("fit-over-train");
    let run = d.join("run");
    std::fs::create_dir_all(&run).unwrap();
    std::fs::write(run.join("model.nerf"), b"a user's model").unwrap();
    let data = d.join("scene");
    ok(&["scene", "--out", s(&data), "--size", "16", "--train", "6"]);
    let e = fails(&[
        "fit",
        "--data",
        s(&data.join("blender")),
        "--target-psnr",
        "20",
        "--minutes",
        "0.01",
        "--out",
        s(&run),
    ]);
    assert!(e.contains("training run") && e.contains("model.nerf"), "{e}");
    assert_eq!(std::fs::read(run.join("model.nerf")).unwrap(), b"a user's model");
}

#[test]
fn a_byte_order_mark_is_read_past() {
    let d = tmp("bom");
    write_colmap(&d, spec(), ColmapText::Text, false).unwrap();
    let opts = LoadOptions { holdout: 4, ..Default::default() };
    let plain = load(&d, Split::Train, opts).unwrap();
    for f in ["cameras.txt", "images.txt", "points3D.txt"] {
        let p = d.join("sparse/0").join(f);
        let mut b = b"\xef\xbb\xbf".to_vec();
        b.extend(std::fs::read(&p).unwrap());
        std::fs::write(&p, b).unwrap();
    }
    let marked = load(&d, Split::Train, opts).unwrap();
    assert_eq!(plain.views.len(), marked.views.len());
    assert_eq!(plain.scene, marked.scene);
}

#[test]
fn output_folders_hold_one_commands_outputs_and_nothing_stale() {
    let d = tmp("outdir");
    let m = model_file();
    let pngs = |dir: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".png") && !n.contains("depth") && !n.contains("opacity"))
            .collect();
        v.sort();
        v
    };
    // a longer render, then a shorter one into the same folder: the shorter one's frames alone
    let out = d.join("orbit");
    ok(&["render", &m, "--orbit", "4", "--size", "8", "--out", s(&out)]);
    assert_eq!(pngs(&out).len(), 4);
    ok(&["render", &m, "--orbit", "2", "--size", "8", "--out", s(&out)]);
    assert_eq!(pngs(&out).len(), 2, "{:?}", pngs(&out));
    // a user's file in the folder: refused, and the file is left as it was
    let mine = d.join("mine");
    std::fs::create_dir_all(&mine).unwrap();
    std::fs::write(mine.join("frame_000.png"), b"my photo").unwrap();
    let e = fails(&["render", &m, "--orbit", "2", "--size", "8", "--out", s(&mine)]);
    assert!(e.contains("frame_000.png") && e.contains("did not write"), "{e}");
    assert_eq!(std::fs::read(mine.join("frame_000.png")).unwrap(), b"my photo");
    let e = fails(&["scene", "--out", s(&mine)]);
    assert!(e.contains("did not write"), "{e}");
    // another command's outputs: refused, named, and left; --force replaces them
    let e = fails(&["scene", "--out", s(&out), "--size", "8"]);
    assert!(e.contains("nerf render") && e.contains("--force"), "{e}");
    assert_eq!(pngs(&out).len(), 2);
    let other = d.join("other");
    ok(&["render", &m, "--orbit", "2", "--size", "8", "--out", s(&other)]);
    ok(&["scene", "--out", s(&other), "--size", "8", "--train", "2", "--force"]);
    assert!(pngs(&other).is_empty() && other.join("room").is_dir());
    // --force never removes a user's file
    let e = fails(&["render", &m, "--orbit", "2", "--size", "8", "--out", s(&mine), "--force"]);
    assert!(e.contains("frame_000.png") && e.contains("even --force"), "{e}");
    assert_eq!(std::fs::read(mine.join("frame_000.png")).unwrap(), b"my photo");
    // a file the user adds beside a render's outputs is not the render's to remove
    std::fs::write(out.join("notes.txt"), b"keep").unwrap();
    let e = fails(&["render", &m, "--orbit", "2", "--size", "8", "--out", s(&out)]);
    assert!(e.contains("notes.txt"), "{e}");
    assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"keep");
}

#[test]
fn mesh_masks_need_photos_with_alpha() {
    let d = tmp("mesh-masks");
    write_colmap(&d.join("cap"), spec(), ColmapText::Binary, false).unwrap();
    let out = d.join("m.ply");
    // the COLMAP photos are opaque JPEGs: no silhouette to compare with
    let e = fails(&["mesh", &model_file(), "--out", s(&out), "--resolution", "16", "--masks", s(&d.join("cap"))]);
    assert!(e.contains("no alpha channel") && e.contains("img_"), "{e}");
}

#[test]
fn an_output_record_never_reaches_outside_its_folder_or_into_a_users_files() {
    let d = tmp("outdir-record");
    let victim = d.join("victim.txt");
    std::fs::write(&victim, b"keep").unwrap();
    // a record naming files outside its folder: they are not the record's
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let record = format!("nerf render\n{}\n../victim.txt\n.\n\n", victim.display());
    std::fs::write(out.join(".nerf-outputs"), record).unwrap();
    ok(&["render", &model_file(), "--orbit", "2", "--size", "8", "--out", s(&out)]);
    assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
    // a file a user puts inside a subfolder of a command's outputs stops the next run
    let sc = d.join("scene");
    ok(&["scene", "--out", s(&sc), "--size", "8", "--train", "2"]);
    std::fs::write(sc.join("room").join("notes.txt"), b"mine").unwrap();
    let e = fails(&["scene", "--out", s(&sc), "--size", "8", "--train", "2"]);
    assert!(e.contains("notes.txt") && e.contains("did not write"), "{e}");
    assert_eq!(std::fs::read(sc.join("room").join("notes.txt")).unwrap(), b"mine");
    // without it, the scene is written again in place
    std::fs::remove_file(sc.join("room").join("notes.txt")).unwrap();
    ok(&["scene", "--out", s(&sc), "--size", "8", "--train", "2"]);
}

/// `fit` claims its folder as the other commands do: an earlier fit's
/// results (minutes of training) are replaced only with --force, a
/// training run's files never.
#[test]
fn fit_replaces_an_earlier_fit_only_with_force_and_a_run_never() {
    let d = tmp("fit-outdir");
    let scene = d.join("scene");
    ok(&["scene", "--out", s(&scene), "--size", "16", "--train", "6"]);
    let data = scene.join("blender");
    // (whether a candidate reaches 5 dB in 0.1 s or not, fit writes its table)
    let fit = |out: &Path, force: bool| {
        let mut args = vec!["fit", "--data", s(&data), "--target-psnr", "5", "--minutes", "0.002", "--out", s(out)];
        if force {
            args.push("--force");
        }
        let o = support::cli::nerf(&args);
        (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned())
    };
    let out = d.join("fit");
    fit(&out, false);
    let table = std::fs::read(out.join("fit.csv")).unwrap();
    let (done, e) = fit(&out, false);
    assert!(!done && e.contains("earlier run of nerf fit") && e.contains("--force"), "{e}");
    assert_eq!(std::fs::read(out.join("fit.csv")).unwrap(), table, "left as it was");
    fit(&out, true);
    assert!(out.join("fit.csv").is_file() && out.join(".nerf-outputs").is_file());
    // a training run's folder: refused with or without --force, its model kept
    let train = d.join("run");
    ok(&["train", "--data", s(&data), "--iters", "2", "--val-views", "0", "--out", s(&train)]);
    let model = std::fs::read(train.join("model.nerf")).unwrap();
    for force in [false, true] {
        let (done, e) = fit(&train, force);
        assert!(!done && e.contains("a training run's") && e.contains("even --force"), "{e}");
    }
    assert_eq!(std::fs::read(train.join("model.nerf")).unwrap(), model);
}
