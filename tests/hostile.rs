//! Hostile command lines, one or more per kind of misbehaviour: values out
//! of range (refused at parse time, naming the flag and its range), outputs
//! aimed at inputs or special files (refused, nothing touched), runs that
//! would overwrite or share a run folder, `--resume` with settings that
//! differ from the checkpoint's, and a reader that closes the pipe. Each
//! case checks the exit status, the one-line message and the files.

mod support;

use std::path::Path;
use std::process::{Command, Stdio};
use support::cli::{blender_scene, fails, nerf, ok, s, tmp, BIN};

fn model_file() -> String {
    format!("{}/models/scene.nerf", env!("CARGO_MANIFEST_DIR"))
}

/// Fails with one line naming every needle.
fn fails_naming(args: &[&str], needles: &[&str]) {
    let e = fails(args);
    for n in needles {
        assert!(e.contains(n), "nerf {args:?}: {n:?} not in {e}");
    }
}

/// Every file under `dir` with its bytes, sorted by path.
fn snapshot(dir: &Path) -> Vec<(std::path::PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn numbers_out_of_range_are_refused_naming_the_flag_and_range() {
    let m = model_file();
    let d = tmp("hostile-ranges");
    let out = d.join("out");
    let cases: &[(&[&str], &str)] = &[
        (&["train", "--data", "x", "--out", "y", "--minutes=-1"], "--minutes"),
        (&["train", "--data", "x", "--out", "y", "--minutes", "NaN"], "--minutes"),
        (&["train", "--data", "x", "--out", "y", "--iters", "0"], "--iters"),
        (&["train", "--data", "x", "--out", "y", "--iters", "5", "--log-every", "0"], "--log-every"),
        (&["train", "--data", "x", "--out", "y", "--iters", "5", "--downscale", "0"], "--downscale"),
        (&["train", "--data", "x", "--out", "y", "--iters", "5", "--llffhold", "0"], "--llffhold"),
        (&["render", &m, "--orbit", "1", "--size", "0", "--out", s(&out)], "--size"),
        (&["render", &m, "--orbit", "0", "--out", s(&out)], "--orbit"),
        (&["render", &m, "--orbit", "2", "--size", "100000", "--out", s(&out)], "--size"),
        (&["eval", &m, "--data", "x", "--split", "val", "--coarse", "0"], "--coarse"),
        (&["eval", &m, "--data", "x", "--split", "val", "--fine", "99999"], "--fine"),
        (&["eval", &m, "--data", "x", "--split", "val", "--early-stop", "2"], "--early-stop"),
        (&["fit", "--data", "x", "--target-psnr", "inf", "--out", s(&out)], "--target-psnr"),
        (&["scene", "--out", s(&out), "--size", "0"], "--size"),
    ];
    for (args, flag) in cases {
        let o = nerf(args);
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "nerf {args:?}: {e}");
        assert!(e.contains(flag) && e.contains("expected a number from"), "nerf {args:?}: {e}");
    }
    assert!(!out.exists(), "nothing written");
    // in range one by one, too much together: the GIF's memory is checked before rendering
    let e = fails(&["render", &m, "--orbit", "10000", "--size", "4096", "--out", s(&out)]);
    assert!(e.contains("GB in memory") && e.contains("--size"), "{e}");
    assert!(!out.exists(), "nothing written");
}

#[test]
fn outputs_never_replace_inputs_or_special_files() {
    let d = tmp("hostile-outputs");
    let data = blender_scene(&d, 16, 4);
    let before = snapshot(&data);
    let m = model_file();
    fails_naming(
        &["eval", &m, "--data", s(&data), "--split", "val", "--save", s(&data.join("val"))],
        &["--save", "inside the dataset"],
    );
    fails_naming(
        &["render", &m, "--data", s(&data), "--split", "val", "--out", s(&data)],
        &["--out", "inside the dataset"],
    );
    fails_naming(&["tradeoff", &m, "--data", s(&data), "--out", s(&data.join("t"))], &["--out", "inside the dataset"]);
    fails_naming(
        &["train", "--data", s(&data), "--iters", "2", "--out", s(&data.join("run"))],
        &["--out", "inside the dataset"],
    );
    assert_eq!(snapshot(&data), before, "the dataset is untouched");
    // export onto its own input
    let f32_model = d.join("m.nerf");
    std::fs::copy(&m, &f32_model).unwrap();
    let bytes = std::fs::read(&f32_model).unwrap();
    fails_naming(&["export", s(&f32_model), "--bits", "8", "--out", s(&f32_model)], &["--out", "is the input file"]);
    assert_eq!(std::fs::read(&f32_model).unwrap(), bytes);
    // an existing file that is not a model (a photo) is not replaced
    let photo = d.join("photo.png");
    std::fs::copy(data.join("train/r_0.png"), &photo).unwrap();
    let png = std::fs::read(&photo).unwrap();
    fails_naming(&["export", s(&f32_model), "--bits", "8", "--out", s(&photo)], &["photo.png", "not a model file"]);
    assert_eq!(std::fs::read(&photo).unwrap(), png);
    // a symbolic link and a FIFO at the output path are refused, their targets untouched
    let target = d.join("target.nerf");
    std::fs::write(&target, b"keep").unwrap();
    let link = d.join("link.nerf");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    fails_naming(&["export", s(&f32_model), "--bits", "8", "--out", s(&link)], &["link.nerf", "symbolic link"]);
    assert_eq!(std::fs::read(&target).unwrap(), b"keep");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    let fifo = d.join("fifo.nerf");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    fails_naming(&["export", s(&f32_model), "--bits", "8", "--out", s(&fifo)], &["fifo.nerf", "not a regular file"]);
    // the user's own files in the output folder are left alone
    let run = d.join("run");
    std::fs::create_dir_all(&run).unwrap();
    std::fs::write(run.join("notes.tmp"), b"mine").unwrap();
    std::fs::write(run.join("model.nerf.tmp"), b"mine too").unwrap();
    ok(&["train", "--data", s(&data), "--iters", "2", "--out", s(&run), "--val-views", "0"]);
    assert_eq!(std::fs::read(run.join("notes.tmp")).unwrap(), b"mine");
    assert_eq!(std::fs::read(run.join("model.nerf.tmp")).unwrap(), b"mine too");
}

#[test]
fn a_run_folder_is_never_overwritten_or_shared() {
    let d = tmp("hostile-runs");
    let data = blender_scene(&d, 16, 4);
    let run = d.join("run");
    let train = |iters: &str, extra: &[&str]| {
        let mut args = vec!["train", "--data", s(&data), "--iters", iters, "--out", s(&run), "--val-views", "0"];
        args.extend_from_slice(extra);
        args.iter().map(|a| a.to_string()).collect::<Vec<_>>()
    };
    let run_args = |extra: &[&str]| {
        let a = train("3", extra);
        nerf(&a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    assert!(run_args(&[]).status.success());
    let model = std::fs::read(run.join("model.nerf")).unwrap();
    // a second run into the folder: refused, the first run's files kept
    let o = run_args(&[]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("holds a run") && e.contains("--resume") && e.contains("--force"), "{e}");
    assert_eq!(std::fs::read(run.join("model.nerf")).unwrap(), model);
    // --resume with other settings than the checkpoint's: refused, naming them
    let o = run_args(&["--resume", "--downscale", "2"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("--downscale 2 differs"), "{e}");
    let o = run_args(&["--resume", "--preset", "fast"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("differ from the checkpoint") && e.contains("n_fine"), "{e}");
    // --resume on other data: refused, naming --data
    let other = blender_scene(&d.join("other"), 16, 4);
    let mut a = train("3", &["--resume"]);
    a[2] = s(&other).to_string();
    let o = nerf(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let e = String::from_utf8_lossy(&o.stderr);
    let named = e.contains(&format!("--data {}", other.display())) && e.contains("the run trained on");
    assert!(!o.status.success() && named && e.contains("--force"), "{e}");
    // while a run holds the folder, another is refused
    let a = train("100000", &["--force"]);
    let mut first = Command::new(BIN).args(&a).stderr(Stdio::null()).spawn().unwrap();
    let lock_held = || {
        // refused either way, before writing: for the lock, or for the downscale
        let o = run_args(&["--resume", "--downscale", "2"]);
        String::from_utf8_lossy(&o.stderr).contains("another process")
    };
    let start = std::time::Instant::now();
    let mut seen = false;
    while start.elapsed().as_secs() < 20 && !seen {
        std::thread::sleep(std::time::Duration::from_millis(200));
        seen = lock_held();
    }
    first.kill().unwrap();
    first.wait().unwrap();
    assert!(seen, "a second run into a busy folder must be refused");
    // --force starts over
    assert!(run_args(&["--force"]).status.success());
}

#[test]
fn a_closed_pipe_ends_commands_quietly() {
    let d = tmp("hostile-pipe");
    let data = blender_scene(&d, 16, 4);
    let m = model_file();
    let mut child = Command::new(BIN)
        .args(["eval", &m, "--data", s(&data), "--split", "val"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take()); // the reader is gone before eval prints
    let o = child.wait_with_output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!e.contains("panicked"), "{e}");
    assert!(o.status.success(), "{e}");
}

#[test]
fn a_damaged_checkpoint_is_refused_and_left_in_place() {
    let d = tmp("hostile-checkpoint");
    let data = blender_scene(&d, 16, 4);
    let run = d.join("run");
    ok(&["train", "--data", s(&data), "--iters", "2", "--out", s(&run), "--val-views", "0"]);
    let ckpt = run.join("checkpoint.bin");
    let good = std::fs::read(&ckpt).unwrap();
    assert_eq!(&good[..8], b"NERFCKPT");
    let resume = ["train", "--data", s(&data), "--iters", "4", "--out", s(&run), "--val-views", "0", "--resume"];
    // a flipped bit in the payload (the CRC-32), a cut file (the length), another version
    let mut flipped = good.clone();
    flipped[good.len() / 2] ^= 1;
    let mut version = good.clone();
    version[8] = good[8].wrapping_add(1); // the version after this build's
    for bad in [flipped, good[..good.len() - 3].to_vec(), version] {
        std::fs::write(&ckpt, &bad).unwrap();
        fails_naming(&resume, &["checkpoint.bin", "not a valid checkpoint"]);
        assert_eq!(std::fs::read(&ckpt).unwrap(), bad, "the damaged file is kept for the user");
    }
    std::fs::write(&ckpt, &good).unwrap();
    ok(&resume);
}

#[test]
fn outputs_get_the_usual_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let d = tmp("hostile-mode");
    let out = d.join("m8.nerf");
    ok(&["export", &model_file(), "--bits", "8", "--out", s(&out)]);
    // 0666 less the umask, as any file a program creates (not the 0600 of a private temporary file)
    let umask = umask_of_children();
    assert_eq!(std::fs::metadata(&out).unwrap().permissions().mode() & 0o777, 0o666 & !umask);
}

/// The umask a child shell reports (inherited from this process).
fn umask_of_children() -> u32 {
    let out = Command::new("sh").args(["-c", "umask"]).output().unwrap();
    u32::from_str_radix(String::from_utf8_lossy(&out.stdout).trim(), 8).unwrap()
}

/// A model never replaces a run's checkpoint, and another model or a mesh
/// replaces a file only with `--force`; a configuration with a key written
/// twice, a learning rate out of range, or one that an open scene's
/// proposal grid cannot serve is refused at start, naming the field.
#[test]
fn outputs_replace_only_what_force_allows_and_configurations_are_checked_at_start() {
    let d = tmp("hostile-force");
    let data = blender_scene(&d, 16, 4);
    let run = d.join("run");
    ok(&["train", "--data", s(&data), "--iters", "2", "--out", s(&run), "--val-views", "0"]);
    let (model, ckpt) = (run.join("model.nerf"), run.join("checkpoint.bin"));
    let before = std::fs::read(&ckpt).unwrap();
    for force in [&[][..], &["--force"][..]] {
        let args = [&["export", s(&model), "--bits", "8", "--out", s(&ckpt)][..], force].concat();
        fails_naming(&args, &["checkpoint.bin", "training checkpoint"]);
    }
    assert_eq!(std::fs::read(&ckpt).unwrap(), before);
    let other = d.join("other.nerf");
    ok(&["export", s(&model), "--bits", "8", "--out", s(&other)]);
    let int8 = std::fs::read(&other).unwrap();
    fails_naming(&["export", s(&model), "--bits", "16", "--out", s(&other)], &["other.nerf", "--force"]);
    assert_eq!(std::fs::read(&other).unwrap(), int8);
    ok(&["export", s(&model), "--bits", "16", "--out", s(&other), "--force"]);
    assert_ne!(std::fs::read(&other).unwrap(), int8);
    // a mesh over a file of the user's, or a folder
    let mesh = d.join("notes.ply");
    std::fs::write(&mesh, b"mine").unwrap();
    fails_naming(&["mesh", s(&model), "--out", s(&mesh), "--resolution", "8"], &["notes.ply", "--force"]);
    assert_eq!(std::fs::read(&mesh).unwrap(), b"mine");
    std::fs::create_dir_all(d.join("folder.ply")).unwrap();
    fails_naming(&["mesh", s(&model), "--out", s(&d.join("folder.ply")), "--resolution", "8"], &["is a folder"]);
    // (a model of a few steps: its density is low, so a threshold it reaches)
    ok(&["mesh", s(&model), "--out", s(&mesh), "--resolution", "8", "--threshold", "0.5", "--force"]);
    assert_ne!(std::fs::read(&mesh).unwrap(), b"mine");
    // configurations
    let config = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let train = |data: &Path, cfg: &Path, out: &str| {
        let (data, cfg, out) = (s(data).to_owned(), s(cfg).to_owned(), s(&d.join(out)).to_owned());
        fails(&["train", "--data", &data, "--config", &cfg, "--iters", "2", "--out", &out])
    };
    let twice = config("twice.json", r#"{"sampling": {"n_coarse": 8}, "sampling": {"n_main": 8}}"#);
    let e = train(&data, &twice, "r1");
    assert!(e.contains("twice.json") && e.contains("the key `sampling` appears twice"), "{e}");
    for (lr, shown) in [("1e30", "1e30"), ("1e308", "inf"), ("0", "0"), ("-0.5", "-0.5")] {
        let e = train(&data, &config("lr.json", &format!(r#"{{"lr": {lr}}}"#)), "r2");
        assert!(e.contains(&format!("optimiser.lr {shown} must be a step size in (0, 1]")), "{lr}: {e}");
    }
    let llff = d.join("scene/llff");
    for n_main in ["0", "65535"] {
        let e = train(&llff, &config("main.json", &format!(r#"{{"n_main": {n_main}}}"#)), "r3");
        assert!(e.contains("sampling.n_main must be 1..=255") && e.contains("proposal_res 0"), "{n_main}: {e}");
    }
    assert!(!d.join("r1").join("model.nerf").exists() && !d.join("r3").join("model.nerf").exists());
}

/// Messages that lead somewhere: a folder holding only a model is not told
/// to resume, a resume with another seed is refused, a failed run leaves no
/// empty folder behind, and `web` writes nothing for a damaged model.
#[test]
fn messages_point_to_what_works_and_failures_leave_no_folders() {
    let d = tmp("hostile-messages");
    let data = blender_scene(&d, 16, 4);
    let run = d.join("run");
    ok(&["train", "--data", s(&data), "--iters", "2", "--out", s(&run), "--val-views", "0"]);
    fails_naming(
        &["train", "--data", s(&data), "--iters", "4", "--out", s(&run), "--resume", "--seed", "7"],
        &["--seed 7 differs from the checkpoint's 0"],
    );
    let only_model = d.join("only_model");
    std::fs::create_dir_all(&only_model).unwrap();
    std::fs::copy(run.join("model.nerf"), only_model.join("model.nerf")).unwrap();
    let e = fails(&["train", "--data", s(&data), "--iters", "2", "--out", s(&only_model)]);
    assert!(e.contains("no checkpoint to resume from") && e.contains("--force") && !e.contains("--resume"), "{e}");
    // a run that fails at its start (its data missing) leaves no folder
    let gone = d.join("gone");
    fails(&["train", "--data", s(&d.join("no-such-data")), "--iters", "2", "--out", s(&gone)]);
    assert!(!gone.exists());
    // the run's Blender scene moved: nothing records which scene it was, so the way back is named
    let moved = d.join("moved data");
    std::fs::rename(&data, &moved).unwrap();
    fails_naming(
        &["train", "--data", s(&moved), "--iters", "4", "--out", s(&run), "--resume", "--val-views", "0"],
        &["the run trained on", "nothing recorded tells whether this is the same capture", "resume with --data"],
    );
    fails_naming(
        &["train", "--data", s(&moved), "--iters", "6", "--out", s(&run), "--resume", "--llffhold", "4"],
        &["loading flags (--llffhold 4 --scene auto) differ from the run's (--llffhold 8 --scene auto)"],
    );
    fails_naming(
        &["train", "--data", s(&moved), "--iters", "2", "--out", s(&d.join("r")), "--sparse-model", "1"],
        &["--sparse-model 1: only a COLMAP capture", "a Blender capture"],
    );
    let broken = d.join("broken.nerf");
    std::fs::write(&broken, b"NERF and then nothing").unwrap();
    let site = d.join("site");
    let o = nerf(&["web", s(&broken), "--out", s(&site)]);
    assert!(!o.status.success());
    assert!(!site.exists(), "web made its folder for a damaged model");
}

/// Every file name under `dir` (relative), sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        snapshot(dir).into_iter().map(|(p, _)| p.strip_prefix(dir).unwrap().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn an_interrupted_render_or_scene_leaves_what_its_rerun_replaces() {
    let d = tmp("hostile-interrupt");
    let model = model_file();
    let out = d.join("frames");
    let cases: [(&str, Vec<&str>, &str); 2] = [
        ("render", vec!["render", &model, "--orbit", "2000", "--size", "24", "--out", s(&out)], "orbit_001.png"),
        ("scene", vec!["scene", "--size", "64", "--out", s(&out)], "blender"),
    ];
    for (what, args, first) in cases {
        let child = Command::new(BIN).args(&args).stderr(Stdio::piped()).spawn().unwrap();
        let t = std::time::Instant::now();
        while !out.join(first).exists() {
            assert!(t.elapsed().as_secs() < 60, "{what}: nothing written");
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        // SAFETY: a signal to the child this test started.
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
        let o = child.wait_with_output().unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{what}: {e}");
        assert!(e.contains("interrupted after") && e.contains("the same command replaces them"), "{what}: {e}");
        assert!(!listing(&out).iter().any(|n| n.contains(".tmp")), "{what}: {:?}", listing(&out));
        // the same command, shorter, replaces every output of the interrupted one
        let rerun: Vec<&str> = args.iter().map(|a| if *a == "2000" { "2" } else { a }).collect();
        ok(&rerun);
        if what == "render" {
            assert!(listing(&out).iter().filter(|n| n.ends_with(".png")).all(|n| n.starts_with("orbit_00")));
        }
        std::fs::remove_dir_all(&out).unwrap();
    }
}

#[test]
fn a_camera_path_frame_too_large_is_refused_before_rendering() {
    let d = tmp("hostile-frame-size");
    let path = d.join("path.json");
    let cam = "[1,0,0,0, 0,1,0,0, 0,0,1,3, 0,0,0,1]";
    std::fs::write(
        &path,
        format!(
            r#"{{"camera_type": "perspective", "render_height": 4096, "render_width": 41, "fps": 1, "seconds": 1,
            "keyframes": [], "camera_path": [{{"camera_to_world": {cam}, "fov": 50, "aspect": 0.01}}]}}"#
        ),
    )
    .unwrap();
    let out = d.join("out");
    fails_naming(
        &["render", &model_file(), "--camera-path", s(&path), "--size", "4096", "--out", s(&out)],
        &["4096×409600", "at most 16384", "--size"],
    );
    assert!(!out.exists(), "nothing written");
}

/// A run that learned something for each photo resumes only on the photos
/// it learned them for.
#[test]
fn a_resume_refuses_a_capture_whose_photos_changed() {
    use nerf_train::dataset::synthetic::{write_colmap, ColmapText, SceneSpec};
    let d = tmp("hostile-resume-photos");
    let data = d.join("capture");
    write_colmap(&data, SceneSpec { size: 16, train: 8, val: 2, test: 0 }, ColmapText::Binary, false).unwrap();
    let config = d.join("appearance.json");
    std::fs::write(&config, r#"{"appearance": true}"#).unwrap();
    let run = d.join("run");
    let args = ["train", "--data", s(&data), "--iters", "2", "--out", s(&run), "--val-views", "0"];
    ok(&[&args[..], &["--config", s(&config)]].concat());
    // moved, the same capture resumes from its new folder, with a note
    let moved = d.join("moved capture");
    std::fs::rename(&data, &moved).unwrap();
    let o = nerf(&["train", "--data", s(&moved), "--iters", "3", "--out", s(&run), "--resume", "--val-views", "0"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && e.contains("note: the run trained on") && e.contains("resuming with it"), "{e}");
    // another capture in the run's first folder: 6 photos where the run learned 8 colour corrections
    write_colmap(&data, SceneSpec { size: 16, train: 6, val: 2, test: 0 }, ColmapText::Binary, false).unwrap();
    let mut more = args.to_vec();
    more[4] = "5";
    let e = fails(&[&more[..], &["--resume"]].concat());
    assert!(e.contains("learned a colour correction for each of its") && e.contains("--force"), "{e}");
}
