//! Hostile inputs to the `nerf` binary, end to end: missing, unreadable and
//! corrupt files, an unwritable output directory, a full disk, a read-only
//! file system, and kill or Ctrl-C during training. Each gives a one-line
//! error naming the file and a non-zero exit, leaves no half-written output,
//! and a killed or interrupted run continues with `--resume`.

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use support::cli::{fails, ok, s, tmp, BIN};

/// Runs `nerf args`, expects failure with one line on stderr that contains
/// every string in `needles`; returns the line.
fn fails_naming(args: &[&str], needles: &[&str]) -> String {
    let e = fails(args);
    for n in needles {
        assert!(e.contains(n), "nerf {args:?}: {n:?} not in {e}");
    }
    e
}

/// Every file under `dir`, recursively.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                out.extend(files(&p));
            } else {
                out.push(p);
            }
        }
    }
    out
}

fn scene(d: &Path) -> PathBuf {
    let out = d.join("scene");
    scene_into(&out);
    out
}

fn scene_into(out: &Path) {
    ok(&["scene", "--out", s(out), "--size", "16", "--train", "6"]);
}

fn model_file() -> String {
    format!("{}/models/scene.nerf", env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn bad_input_files_give_one_line_errors_naming_them() {
    let d = tmp("inputs");
    let sc = scene(&d);
    let blender = sc.join("blender");
    let train = |data: &Path, fmt: &str| {
        let out = d.join("run");
        let args = ["train", "--data", s(data), "--format", fmt, "--iters", "1", "--out", s(&out)];
        args.map(str::to_owned)
    };
    let run = |args: [String; 9], needles: &[&str]| {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        fails_naming(&a, needles)
    };
    // a directory where a model file should be
    fails_naming(&["info", s(&d)], &[s(&d), "cannot read"]);
    fails_naming(&["eval", s(&blender), "--data", s(&blender), "--split", "val"], &[s(&blender)]);
    // a model truncated, with a flipped bit, of another format version
    let m = std::fs::read(model_file()).unwrap();
    let cut = d.join("cut.nerf");
    std::fs::write(&cut, &m[..m.len() / 2]).unwrap();
    fails_naming(&["info", s(&cut)], &["cut.nerf", "truncated"]);
    let mut flipped = m.clone();
    flipped[1000] ^= 4;
    let flip = d.join("flip.nerf");
    std::fs::write(&flip, &flipped).unwrap();
    fails_naming(&["export", s(&flip), "--bits", "8", "--out", s(&d.join("x.nerf"))], &["flip.nerf", "checksum"]);
    // a version newer than this build's is refused, naming the versions it reads
    let (newest, mut newer_bytes) = (nerf_infer::format::FORMAT_VERSION, m.clone());
    newer_bytes[4..6].copy_from_slice(&(newest + 1).to_le_bytes());
    let newer = d.join("newer.nerf");
    std::fs::write(&newer, &newer_bytes).unwrap();
    let (version, range) = (format!("version {}", newest + 1), format!("versions 1 to {newest}"));
    fails_naming(&["info", s(&newer)], &["newer.nerf", &version, &range]);
    assert!(!d.join("x.nerf").exists());

    // corrupt PNG
    let png = blender.join("train/r_0.png");
    let good = std::fs::read(&png).unwrap();
    std::fs::write(&png, b"\x89PNG\r\n\x1a\nnot really").unwrap();
    run(train(&blender, "blender"), &["r_0.png"]);
    std::fs::write(&png, good).unwrap();
    // an image of another size than the rest
    let odd = blender.join("train/r_3.png");
    image::RgbaImage::new(20, 20).save(&odd).unwrap();
    run(train(&blender, "blender"), &["r_3.png", "20x20"]);
    std::fs::remove_file(&odd).unwrap();
    run(train(&blender, "blender"), &["r_3.png", "cannot read"]);
    scene_into(&sc);
    // malformed JSON
    let json = blender.join("transforms_train.json");
    let good = std::fs::read(&json).unwrap();
    std::fs::write(&json, b"{\"camera_angle_x\": 0.69, \"frames\": [").unwrap();
    run(train(&blender, "blender"), &["transforms_train.json"]);
    std::fs::write(&json, good).unwrap();
    // malformed NPY
    let llff = sc.join("llff");
    let npy = llff.join("poses_bounds.npy");
    std::fs::write(&npy, b"\x93NUMPY\x01\x00\x10\x00{'descr': '<f4'}").unwrap();
    run(train(&llff, "llff"), &["poses_bounds.npy"]);
    // nothing of the failed runs was left behind
    assert!(!d.join("run/model.nerf").exists() && !d.join("run/checkpoint.bin").exists());
}

#[test]
fn an_output_path_that_cannot_be_created_fails_cleanly() {
    let d = tmp("unwritable");
    let sc = scene(&d);
    let file = d.join("a-file");
    std::fs::write(&file, b"not a directory").unwrap();
    let under = |name: &str| file.join(name);
    let model = model_file();
    let blender = s(&sc.join("blender")).to_owned();
    fails_naming(&["export", &model, "--bits", "16", "--out", s(&under("m.nerf"))], &[s(&under("m.nerf"))]);
    fails_naming(&["render", &model, "--orbit", "2", "--size", "8", "--out", s(&under("r"))], &[s(&under("r"))]);
    fails_naming(&["train", "--data", &blender, "--iters", "1", "--out", s(&under("run"))], &[s(&under("run"))]);
    fails_naming(&["scene", "--out", s(&under("sc")), "--size", "8"], &[s(&under("sc"))]);
    fails_naming(&["eval", &model, "--data", &blender, "--split", "val", "--save", s(&under("e"))], &[s(&under("e"))]);
    fails_naming(
        &["tradeoff", &model, "--data", &blender, "--views", "1", "--repeats", "1", "--out", s(&under("t"))],
        &[s(&under("t"))],
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"not a directory");
}

/// Runs `script` as root in a private mount namespace (`unshare`), where it
/// can mount small and read-only file systems; returns its stdout.
fn in_mount_namespace(script: &str) -> String {
    let mut cmd = Command::new("unshare");
    // as root, a plain mount namespace; otherwise map the user to root
    let is_root = Command::new("id").arg("-u").output().map(|o| o.stdout == b"0\n").unwrap_or(false);
    cmd.args(if is_root { &["-m"][..] } else { &["-r", "-m"][..] });
    let o = cmd.args(["sh", "-c", script]).output().expect("unshare (util-linux) runs");
    assert!(
        o.status.success(),
        "the namespace script failed (unshare needs root or user namespaces): {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

#[test]
fn a_full_disk_or_read_only_file_system_leaves_nothing_half_written() {
    let d = tmp("disk");
    let sc = scene(&d);
    let (full, ro) = (d.join("full"), d.join("ro"));
    std::fs::create_dir_all(&full).unwrap();
    std::fs::create_dir_all(&ro).unwrap();
    let blender = sc.join("blender");
    let model = model_file();
    // each case: a command that must fail; the script prints its exit
    // status, stderr and the files left on the small file system.
    // (paths here have no spaces; DIR is the file system under test)
    let cases = [
        ("export", format!("export {model} --bits 32 --out DIR/m.nerf")),
        ("train", format!("train --data {} --iters 3 --out DIR/run", s(&blender))),
        ("render", format!("render {model} --orbit 3 --size 96 --out DIR/r")),
        ("scene", "scene --out DIR/sc --size 32".to_owned()),
    ];
    let mut script = format!(
        "set -e; mount -t tmpfs -o size=160k none {full}; mount -t tmpfs -o ro,size=1m none {ro}; \
         head -c 150000 /dev/zero > {full}/filler; set +e\n",
        full = s(&full),
        ro = s(&ro)
    );
    for (name, args) in &cases {
        for (fs, dir) in [("full", &full), ("ro", &ro)] {
            let argv: Vec<String> = args.split(' ').map(|a| format!("'{}'", a.replace("DIR", s(dir)))).collect();
            script.push_str(&format!(
                "'{BIN}' {} 2>/tmp/nerf-err-$$ >/dev/null; echo \"== {name} {fs} rc=$?\"; cat /tmp/nerf-err-$$; \
                 find {} -type f ! -name filler | sed 's/^/left: /'; rm -rf {}/* 2>/dev/null; \
                 head -c 150000 /dev/zero > {}/filler 2>/dev/null || true\n",
                argv.join(" "),
                s(dir),
                s(dir),
                s(dir)
            ));
        }
    }
    script.push_str("rm -f /tmp/nerf-err-$$\n");
    let report = in_mount_namespace(&script);
    println!("{report}");
    let blocks: Vec<&str> = report.split("== ").skip(1).collect();
    assert_eq!(blocks.len(), cases.len() * 2, "{report}");
    for b in blocks {
        let mut lines = b.lines();
        let head = lines.next().unwrap();
        assert!(!head.ends_with("rc=0"), "{head}: should fail");
        let rest: Vec<&str> = lines.collect();
        let errors: Vec<&&str> = rest.iter().filter(|l| l.starts_with("error:")).collect();
        assert_eq!(errors.len(), 1, "{head}: one error line: {rest:?}");
        let e = errors[0];
        let expect = if head.contains(" ro ") { "Read-only file system" } else { "No space left on device" };
        assert!(e.contains(expect) && e.contains(s(&d)), "{head}: {e}");
        for left in rest.iter().filter(|l| l.starts_with("left: ")) {
            // only whole files may remain: a log of whole lines, or finished
            // files written before the disk filled
            let p = &left[6..];
            assert!(!p.ends_with(".tmp"), "{head}: temporary file left: {p}");
            // (`.nerf-outputs`: the output folder's record, written whole)
            assert!(
                p.ends_with("train.jsonl")
                    || p.ends_with(".png")
                    || p.ends_with(".json")
                    || p.ends_with(".nerf-outputs"),
                "{head}: unexpected file left: {p}"
            );
        }
    }
}

fn checkpoint_step(run: &Path) -> u64 {
    let b = std::fs::read(run.join("checkpoint.bin")).unwrap();
    nerf_train::train::Trainer::from_bytes(&b).expect("a whole checkpoint").step
}

/// Steps logged in `train.jsonl`, in order.
fn logged_steps(run: &Path) -> Vec<u64> {
    let log = std::fs::read_to_string(run.join("train.jsonl")).unwrap();
    log.lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).expect("whole JSON lines")["step"].as_u64().unwrap())
        .collect()
}

/// Starts a long training run and waits until it has written a checkpoint.
fn start_long_run(data: &Path, run: &Path, resume: bool) -> std::process::Child {
    let mut args = vec!["train", "--data", s(data), "--iters", "1000000", "--out", s(run)];
    args.extend(["--threads", "1", "--checkpoint-secs", "0.3", "--val-views", "0", "--log-every", "1"]);
    if resume {
        args.push("--resume");
    }
    let child = Command::new(BIN).args(&args).stderr(Stdio::piped()).spawn().unwrap();
    let t0 = Instant::now();
    let ckpt = run.join("checkpoint.bin");
    let before = std::fs::metadata(&ckpt).and_then(|m| m.modified()).ok();
    while std::fs::metadata(&ckpt).and_then(|m| m.modified()).ok() == before {
        assert!(t0.elapsed() < Duration::from_secs(120), "no checkpoint after two minutes");
        std::thread::sleep(Duration::from_millis(50));
    }
    std::thread::sleep(Duration::from_millis(700));
    child
}

#[test]
fn kill_or_ctrl_c_during_training_then_resume_loses_nothing() {
    let d = tmp("kill");
    let data = scene(&d).join("blender");
    let run = d.join("run");

    // SIGKILL: the last checkpoint survives whole; --resume continues from it
    let mut child = start_long_run(&data, &run, false);
    child.kill().unwrap();
    child.wait().unwrap();
    let at_kill = checkpoint_step(&run);
    assert!(at_kill > 0);
    let target = at_kill + 15;
    ok(&[
        "train",
        "--data",
        s(&data),
        "--iters",
        &target.to_string(),
        "--out",
        s(&run),
        "--resume",
        "--log-every",
        "1",
    ]);
    assert_eq!(checkpoint_step(&run), target);
    let steps = logged_steps(&run);
    assert!(steps.windows(2).all(|w| w[1] == w[0] + 1), "log steps not consecutive after resume: {steps:?}");
    assert_eq!(*steps.last().unwrap(), target);

    // Ctrl-C: the run checkpoints the step it reached and says how to go on
    let child = start_long_run(&data, &run, true);
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let o = child.wait_with_output().unwrap();
    let e = String::from_utf8(o.stderr).unwrap();
    assert!(!o.status.success(), "interrupted run should exit non-zero");
    let line = e.lines().find(|l| l.starts_with("error:")).unwrap_or_else(|| panic!("no error line: {e}"));
    assert!(line.contains("interrupted at step") && line.contains("--resume"), "{line}");
    let step: u64 = line.split("step ").nth(1).unwrap().split(':').next().unwrap().parse().unwrap();
    assert_eq!(checkpoint_step(&run), step, "the checkpoint holds the step the run reached");
    assert!(step > target);
    let m = std::fs::read(run.join("model.nerf")).unwrap();
    nerf_infer::Model::from_bytes(&m).expect("a whole model");
    assert_eq!(*logged_steps(&run).last().unwrap(), step);
    assert!(files(&run).iter().all(|p| !p.to_string_lossy().ends_with(".tmp")));
}
