//! `nerf bench`: every scene of a suite trained and scored at its
//! published protocol, one table (Markdown, CSV, JSON) and one plot.
//!
//! The output folder is the only meeting point of a bench's parts:
//! `bench.json` records the suite and the flags (every task checks it),
//! `scenes/NAME/` holds a scene's run, its int8 export and its row
//! (`result.json`, written last and atomically), and each scene folder is
//! locked while a task works in it. A run without `--task` runs each scene
//! not yet done as a task of its own (a child process, so each scene's peak
//! memory is its own and a crash is one failed row), then gathers.

use super::{num_in, CmdError, CmdResult};
use nerf_train::config::Preset;
use std::path::PathBuf;

mod record;
mod score;
pub mod suite;
mod table;
mod task;

pub use record::Settings;

/// Arguments of `nerf bench`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("budget").args(["iters", "minutes"])), args_override_self = true)]
pub struct Args {
    /// Suite folder: scene folders (nerf_synthetic, nerf_llff_data or captures of your own), or one scene.
    /// Scenes are run in order of folder name; `--list` prints them with their task index.
    pub(crate) suite: PathBuf,
    /// Output folder (created; outside the suite): bench.json, scenes/NAME/ (run, int8 model, result.json),
    /// table.md, table.csv, table.json, psnr_minutes.png.
    #[arg(long, required_unless_present = "list")]
    pub(crate) out: Option<PathBuf>,
    /// Train each scene for this many minutes of training.
    #[arg(long, value_name = "0.001..=100000.0", value_parser = num_in(0.001f64, 100_000.0))]
    pub(crate) minutes: Option<f64>,
    /// Train each scene for this many steps.
    #[arg(long, value_name = "1..=1000000000", value_parser = num_in(1u64, 1_000_000_000))]
    pub(crate) iters: Option<u64>,
    /// Run only the scene of this index (0-based, in `--list`'s order) into --out: one task of a job
    /// array ($SLURM_ARRAY_TASK_ID, $JOB_COMPLETION_INDEX). `--gather` writes the table afterwards.
    #[arg(long, value_name = "I", conflicts_with_all = ["gather", "list"])]
    pub(crate) task: Option<usize>,
    /// Write the table from what the tasks left in --out, naming the scenes with no result or a failed one.
    #[arg(long, conflicts_with = "list")]
    pub(crate) gather: bool,
    /// Print the suite's scenes with their task index, kind and protocol, and their count; run nothing.
    #[arg(long)]
    pub(crate) list: bool,
    /// Downscale of the captures of your own (COLMAP, instant-ngp, nerfstudio); the paper's suites keep
    /// their protocol (synthetic at full size, LLFF at 1/4).
    #[arg(long, default_value_t = 8, value_name = "1..=64", value_parser = num_in(1u32, 64))]
    pub(crate) downscale: u32,
    /// Named configuration for every scene [default: features].
    #[arg(long, value_enum)]
    pub(crate) preset: Option<Preset>,
    /// Configuration as JSON for every scene (as `nerf train --config`).
    #[arg(long)]
    pub(crate) config: Option<PathBuf>,
    /// Seed of every scene's training.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    /// Worker threads of training and scoring (0: all cores); µs per ray is always timed on one.
    #[arg(long, default_value_t = 0, value_name = "0..=1024", value_parser = num_in(0usize, 1024))]
    pub(crate) threads: usize,
}

/// Runs `nerf bench`.
pub fn run(a: Args) -> CmdResult {
    if a.list {
        return list(&a);
    }
    let out = a.out.clone().ok_or(CmdError::Flag { flag: "--out", reason: "is required".into() })?;
    if a.gather {
        let settings = Settings::read(&out)?;
        return table::gather(&settings, &out);
    }
    if a.minutes.is_none() && a.iters.is_none() {
        return Err(CmdError::Usage("give a training budget per scene: --minutes or --iters".into()));
    }
    super::refuse_inside(&out, "--out", &a.suite)?;
    let settings = Settings::from_args(&a)?;
    let n = settings.scenes.len();
    if let Some(i) = a.task.filter(|&i| i >= n) {
        return Err(CmdError::Flag {
            flag: "--task",
            reason: format!("{i}: the suite {} has {n} scenes (tasks 0 to {})", a.suite.display(), n - 1),
        });
    }
    settings.claim(&out)?;
    match a.task {
        Some(i) => task::run(&settings, i, &out, a.threads),
        None => sequential(&settings, &out),
    }
}

/// `--list`: the scenes, one line each, then their count.
fn list(a: &Args) -> CmdResult {
    let scenes = suite::discover(&a.suite, a.downscale)?;
    for (i, s) in scenes.iter().enumerate() {
        out!(
            "{i}\t{}\t{}\t1/{} size\t{} split\t{}",
            s.name,
            s.kind.name(),
            s.downscale,
            s.scored_split().name(),
            s.dir.display()
        );
    }
    eprintln!("{} scenes: tasks 0 to {}", scenes.len(), scenes.len() - 1);
    Ok(())
}

/// Every scene not yet done as a task of its own (this program again with
/// `--task I`, in its own process group so that a Ctrl-C reaches it once,
/// passed on by this process), one after the other, then the table.
fn sequential(settings: &Settings, out: &std::path::Path) -> CmdResult {
    // on Linux the running binary itself, even if a rebuild has replaced its file since
    let exe = match std::path::Path::new("/proc/self/exe") {
        p if cfg!(target_os = "linux") && p.exists() => p.to_path_buf(),
        _ => std::env::current_exe().map_err(CmdError::within("cannot find this program to run its tasks"))?,
    };
    // `bench` first, then `--task I`, then the rest as given (a `--` among them stays last)
    let args: Vec<std::ffi::OsString> = std::env::args_os().skip(1).collect();
    let at = args.iter().position(|a| a == "bench").map_or(0, |i| i + 1);
    super::interrupt::forward_to(0);
    let interrupted = |name: &str| {
        Err(CmdError::Interrupted(format!(
            "interrupted during scene {name}: the same command resumes the suite where it stopped"
        )))
    };
    let n = settings.scenes.len();
    for (i, s) in settings.scenes.iter().enumerate() {
        if super::interrupt::received() {
            return interrupted(&s.name);
        }
        if task::done(out, s) {
            eprintln!("[{}/{n}] {}: done before, kept", i + 1, s.name);
            continue;
        }
        eprintln!("[{}/{n}] {} ({}, 1/{} size)", i + 1, s.name, s.kind.name(), s.downscale);
        let mut task_args = args.clone();
        task_args.splice(at..at, ["--task".into(), i.to_string().into()]);
        let mut cmd = std::process::Command::new(&exe);
        cmd.args(&task_args);
        #[cfg(unix)]
        std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
        let mut child = cmd.spawn().map_err(CmdError::within(format!("cannot start task {i} ({})", exe.display())))?;
        super::interrupt::forward_to(child.id());
        // an interrupt between the start and the line above was counted but not passed on
        if super::interrupt::received() {
            #[cfg(unix)]
            // SAFETY: a signal to the child this process started and has not yet waited for.
            unsafe {
                libc::kill(child.id() as libc::pid_t, libc::SIGTERM);
            }
        }
        let status = child.wait().map_err(CmdError::within(format!("task {i}")))?;
        super::interrupt::forward_to(0);
        if super::interrupt::received() {
            return interrupted(&s.name);
        }
        if !status.success() {
            task::record_crash(out, s, i, status)?;
            eprintln!("[{}/{n}] {}: failed (its row says why); going on", i + 1, s.name);
        }
    }
    super::interrupt::reset();
    table::gather(settings, out)
}
