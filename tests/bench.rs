//! `nerf bench` end to end on two tiny built-in scenes: the table, its
//! tasks run apart and gathered, resuming, failed scenes and bad input.

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use support::cli::{fails, nerf, ok, s, tmp, BIN};

fn suite(d: &Path) -> (PathBuf, PathBuf) {
    support::cli::bench_suite(d)
}

/// `nerf bench SUITE --out OUT` with the tiny configuration, `iters`
/// steps, one thread (the same model whatever the timing), and `extra`.
fn bench_args(suite: &Path, cfg: &Path, out: &Path, iters: u32, extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = ["bench", s(suite), "--out", s(out), "--preset", "fast", "--config", s(cfg)]
        .iter()
        .map(|x| x.to_string())
        .collect();
    v.extend(["--iters".into(), iters.to_string(), "--downscale".into(), "1".into(), "--threads".into(), "1".into()]);
    v.extend(extra.iter().map(|x| x.to_string()));
    v
}

fn run(args: &[String]) -> std::process::Output {
    nerf(&args.iter().map(String::as_str).collect::<Vec<_>>())
}

/// The rows of `out/table.json`.
fn rows(out: &Path) -> Vec<serde_json::Value> {
    serde_json::from_str(&std::fs::read_to_string(out.join("table.json")).unwrap()).unwrap()
}

/// What a row says of the model, not of the time it took.
fn scores(r: &serde_json::Value) -> String {
    format!(
        "{} {} {} {} {} {}",
        r["scene"], r["split"], r["steps"], r["f32"]["psnr"], r["int8"]["psnr"], r["f32"]["ssim"]
    )
}

#[test]
fn a_suite_gives_one_table_and_its_tasks_run_apart_give_the_same_rows() {
    let d = tmp("bench_suite");
    let (suite, cfg) = suite(&d);
    let listed = ok(&["bench", s(&suite), "--list", "--downscale", "1"]);
    let names: Vec<&str> = listed.lines().map(|l| l.split('\t').nth(1).unwrap()).collect();
    assert_eq!(names, ["lego", "object"], "{listed}");

    let seq = d.join("seq");
    let o = run(&bench_args(&suite, &cfg, &seq, 150, &[]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let table = std::fs::read_to_string(seq.join("table.md")).unwrap();
    assert!(table.contains("| 0 | lego | synthetic, 16×16, test (6 views) | 150 |"), "{table}");
    assert!(table.contains("| 1 | object | capture, 16×16, test"), "{table}");
    assert!(table.contains("| 32.54 | 0.961 |"), "the paper's lego figure beside its row: {table}");
    let csv = std::fs::read_to_string(seq.join("table.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    let image = image::open(seq.join("psnr_minutes.png")).unwrap().to_rgb8();
    assert!(image.pixels().filter(|p| p.0 == [210, 40, 40]).count() > 100, "the published line is drawn");
    let seq_rows = rows(&seq);
    for r in &seq_rows {
        let psnr = r["f32"]["psnr"].as_f64().unwrap();
        // after one step the field scores 7 to 9 dB; 150 steps bring it past 12
        assert!(psnr > 12.0 && (psnr - r["int8"]["psnr"].as_f64().unwrap()).abs() < 0.5, "{r}");
        assert!(r["peak_mib"].as_f64().unwrap() > 1.0 && r["f32"]["us_per_ray"].as_f64().unwrap() > 0.0, "{r}");
    }

    // the same bench as a job array would run it: each task alone, then the table
    let apart = d.join("apart");
    for i in ["1", "0"] {
        let o = run(&bench_args(&suite, &cfg, &apart, 150, &["--task", i]));
        assert!(o.status.success(), "task {i}: {}", String::from_utf8_lossy(&o.stderr));
    }
    assert!(!apart.join("table.md").exists(), "a task writes its row, not the table");
    ok(&["bench", s(&suite), "--out", s(&apart), "--gather"]);
    let apart_rows = rows(&apart);
    assert_eq!(apart_rows.len(), 2);
    for (a, b) in seq_rows.iter().zip(&apart_rows) {
        assert_eq!(scores(a), scores(b));
    }

    // a rerun keeps what is done
    let result = seq.join("scenes/lego/result.json");
    let before = std::fs::read(&result).unwrap();
    let o = run(&bench_args(&suite, &cfg, &seq, 150, &[]));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("lego: done before, kept"), "{err}");
    assert_eq!(std::fs::read(&result).unwrap(), before);
    // other flags do not mix their rows with these
    let e = fails(&bench_args(&suite, &cfg, &seq, 151, &[]).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(e.contains("holds a bench run with --iters 150"), "{e}");
}

#[test]
fn a_failed_scene_is_a_row_with_its_error_and_the_others_complete() {
    let d = tmp("bench_failed");
    let (suite, cfg) = suite(&d);
    let photo = suite.join("object/images");
    let first = std::fs::read_dir(&photo).unwrap().map(|e| e.unwrap().path()).min().unwrap();
    let kept = d.join("kept.jpg");
    std::fs::rename(&first, &kept).unwrap();
    let out = d.join("out");
    let o = run(&bench_args(&suite, &cfg, &out, 150, &[]));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("1 of 2 scenes failed"), "{err}");
    let r = rows(&out);
    assert!(r[0]["error"].is_null() && r[0]["f32"]["psnr"].as_f64().unwrap() > 12.0, "{:?}", r[0]);
    let name = first.file_name().unwrap().to_string_lossy().into_owned();
    assert!(r[1]["error"].as_str().unwrap().contains(&name), "the row names the missing photo: {:?}", r[1]);
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(table.contains("- object failed: ") && table.contains(&name), "{table}");
    // the photo back, the same command runs the failed scene again and keeps the other
    std::fs::rename(&kept, &first).unwrap();
    let o = run(&bench_args(&suite, &cfg, &out, 150, &[]));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("lego: done before, kept"), "{err}");
    assert!(rows(&out).iter().all(|r| r["error"].is_null()));
}

#[test]
fn an_interrupted_task_resumes_and_a_second_process_on_its_index_is_refused() {
    let d = tmp("bench_interrupt");
    let (suite, cfg) = suite(&d);
    let out = d.join("out");
    let args = bench_args(&suite, &cfg, &out, 400, &["--task", "0"]);
    let mut first = Command::new(BIN).args(&args).stderr(std::process::Stdio::piped()).spawn().unwrap();
    let log = out.join("scenes/lego/run/train.jsonl");
    let start = std::time::Instant::now();
    while !log.exists() && start.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    assert!(log.exists(), "the task's training never started");
    let o = run(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("--task 0 (scene lego): another process is running this task"), "{err}");
    // SIGTERM: the training checkpoints and stops, the row says so
    // SAFETY: a signal to the child this test started.
    unsafe { libc::kill(first.id() as i32, libc::SIGTERM) };
    let status = first.wait().unwrap();
    let row: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("scenes/lego/result.json")).unwrap()).unwrap();
    if status.success() {
        // finished before the signal reached it: nothing to resume
        assert!(row["error"].is_null());
        return;
    }
    assert!(row["error"].as_str().unwrap().contains("interrupted"), "{row}");
    let stopped_at = std::fs::read_to_string(&log).unwrap().lines().count();
    let o = run(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let row: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("scenes/lego/result.json")).unwrap()).unwrap();
    assert!(row["error"].is_null() && row["steps"] == 400, "{row}");
    let lines = std::fs::read_to_string(&log).unwrap();
    assert!(lines.lines().count() >= stopped_at, "the log goes on from the checkpoint");
}

#[test]
fn bad_suites_tasks_and_gathers_are_named() {
    let d = tmp("bench_bad");
    let (suite, cfg) = suite(&d);
    let empty = d.join("empty");
    std::fs::create_dir_all(empty.join("photos")).unwrap();
    let e = fails(&["bench", s(&empty), "--out", s(&d.join("o1")), "--iters", "5"]);
    assert!(e.contains("empty: no scene found"), "{e}");
    let e = fails(
        &bench_args(&suite, &cfg, &d.join("o2"), 5, &["--task", "2"]).iter().map(String::as_str).collect::<Vec<_>>(),
    );
    assert!(e.contains("--task 2: the suite") && e.contains("has 2 scenes (tasks 0 to 1)"), "{e}");
    let e = fails(&["bench", s(&suite), "--out", s(&d.join("o3")), "--gather"]);
    assert!(e.contains("no bench has run here"), "{e}");
    let e = fails(&["bench", s(&suite), "--out", s(&suite.join("out")), "--iters", "5"]);
    assert!(e.contains("inside the dataset folder"), "{e}");
    let e = fails(&["bench", s(&suite), "--out", s(&d.join("o4"))]);
    assert!(e.contains("--minutes or --iters"), "{e}");
    // a folder of someone else's files is not taken over
    let theirs = d.join("theirs");
    std::fs::create_dir_all(&theirs).unwrap();
    std::fs::write(theirs.join("notes.txt"), "mine").unwrap();
    let e = fails(&bench_args(&suite, &cfg, &theirs, 5, &[]).iter().map(String::as_str).collect::<Vec<_>>());
    assert!(e.contains("holds notes.txt and no bench.json"), "{e}");
    assert_eq!(std::fs::read_to_string(theirs.join("notes.txt")).unwrap(), "mine");
    // a gather after one of two tasks names the other
    let half = d.join("half");
    let o = run(&bench_args(&suite, &cfg, &half, 5, &["--task", "1"]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = nerf(&["bench", s(&suite), "--out", s(&half), "--gather"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("task 0 (lego): no result yet"), "{err}");
    assert_eq!(rows(&half).len(), 1);
    assert!(std::fs::read_to_string(half.join("table.md")).unwrap().contains("task 0 (lego): no result"));
}
