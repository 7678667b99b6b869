//! The shipped Slurm scripts against a real Slurm: a one-node cluster on
//! localhost (`scripts/check/slurm_local.sh`, which installs Debian's slurmctld,
//! slurmd, slurm-client and munge when missing and starts the daemons as
//! root), `examples/bench/slurm/submit.sh` submitting a two-task array over
//! two tiny built-in scenes and its dependent gather job, the table
//! checked, the daemons stopped. Ignored by `cargo test`; `.ci/run` runs it
//! (`cargo test --release --test slurm -- --ignored`).

mod support;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};
use support::cli::{s, tmp, BIN};

/// Stops the cluster whose state lives in `dir` when dropped, however the test ends.
struct Cluster(std::path::PathBuf);

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash").arg(repo().join("scripts/check/slurm_local.sh")).arg("stop").arg(&self.0).status();
    }
}

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
#[ignore = "needs root, Debian's Slurm packages and ports 6817-6818: run by .ci/run"]
fn the_shipped_job_array_and_its_gather_job_write_the_table() {
    let d = tmp("slurm");
    let (suite, cfg) = support::cli::bench_suite(&d);

    let state = d.join("slurm");
    let started = Command::new("bash")
        .arg(repo().join("scripts/check/slurm_local.sh"))
        .args(["start", s(&state)])
        .output()
        .unwrap();
    let _cluster = Cluster(state.clone());
    assert!(started.status.success(), "starting Slurm: {}", String::from_utf8_lossy(&started.stderr));
    let conf = state.join("slurm.conf");

    let out = d.join("out");
    let submit = Command::new("bash")
        .arg(repo().join("examples/bench/slurm/submit.sh"))
        .current_dir(&d)
        .args([s(&suite), s(&out), "--iters", "150", "--downscale", "1", "--preset", "fast", "--config", s(&cfg)])
        .env("SLURM_CONF", &conf)
        .env("NERF", BIN)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&submit.stdout);
    assert!(submit.status.success(), "submit.sh: {said} {}", String::from_utf8_lossy(&submit.stderr));
    assert!(said.contains("(2 tasks)"), "{said}");
    let gather_id = said.split_whitespace().last().unwrap().to_string();

    // the gather job ends after both tasks (scontrol keeps ended jobs for MinJobAge)
    let start = Instant::now();
    let state_of = || {
        let o = Command::new("scontrol").args(["show", "job", &gather_id]).env("SLURM_CONF", &conf).output().unwrap();
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        text.split_whitespace().find_map(|w| w.strip_prefix("JobState=").map(str::to_owned)).unwrap_or_default()
    };
    let mut job = state_of();
    while !["COMPLETED", "FAILED", "CANCELLED", "TIMEOUT"].contains(&job.as_str()) {
        assert!(start.elapsed() < Duration::from_secs(600), "gather job {gather_id} still {job} after 10 minutes");
        std::thread::sleep(Duration::from_millis(500));
        job = state_of();
    }
    let logs: Vec<String> = std::fs::read_dir(&*d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with("nerf-bench-"))
        .map(|e| format!("{}:\n{}", e.path().display(), std::fs::read_to_string(e.path()).unwrap_or_default()))
        .collect();
    assert_eq!(job, "COMPLETED", "the gather job: {}", logs.join("\n"));
    let rows: Vec<serde_json::Value> =
        serde_json::from_str(&std::fs::read_to_string(out.join("table.json")).unwrap()).unwrap();
    let names: Vec<&str> = rows.iter().map(|r| r["scene"].as_str().unwrap()).collect();
    assert_eq!(names, ["lego", "object"]);
    for r in &rows {
        assert!(r["error"].is_null() && r["steps"] == 150 && r["f32"]["psnr"].as_f64().unwrap() > 12.0, "{r}");
    }
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(table.contains("| 32.54 | 0.961 |"), "{table}");
}
