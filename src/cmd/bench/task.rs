//! One task: one scene trained (resumed where a checkpoint is), exported
//! to int8, scored, and its row written to `scenes/NAME/result.json`.

use super::score::{self, Scores};
use super::suite::{self, Scene};
use super::Settings;
use crate::cmd::{export, train, CmdError, CmdResult};
use nerf_train::train::Trainer;
use std::path::{Path, PathBuf};

/// A row's file in its scene folder, written last: its presence without
/// an error is what "done" means.
const RESULT: &str = "result.json";

/// One row of the table: a scene's protocol, its training and its scores,
/// or the error that stopped it.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Row {
    /// Task index (the scene's place in the suite).
    pub index: usize,
    /// Scene name.
    pub scene: String,
    /// Kind, which sets the protocol (`synthetic`, `forward-facing`, `capture`).
    pub kind: String,
    /// Downscale factor of training and scoring.
    pub downscale: u32,
    /// The split scored (`test`, or `val` where a synthetic scene ships no test split).
    pub split: String,
    /// Width and height of the scored views, pixels (of the first one).
    pub size: Option<(u32, u32)>,
    /// Views scored.
    pub views: usize,
    /// Training steps.
    pub steps: Option<u64>,
    /// Training minutes (the steps' time, validation renders excluded).
    pub minutes: Option<f64>,
    /// Scores of the f32 model.
    pub f32: Option<Scores>,
    /// Scores of its int8 export (`nerf export --bits 8`).
    pub int8: Option<Scores>,
    /// Worker threads of training and scoring (`--threads`, 0 resolved to
    /// the cores available).
    pub threads: usize,
    /// The task's peak resident memory (training and scoring), MiB.
    pub peak_mib: Option<f64>,
    /// The 2020 NeRF's published PSNR (dB) and SSIM at this protocol, if any.
    pub published: Option<(f64, f64)>,
    /// Validation PSNR (dB, the first two held-out views) against training
    /// minutes, from the run's log, then the scored PSNR at the end.
    pub curve: Vec<(f64, f64)>,
    /// Date (UTC, `YYYY-MM-DD`), the build's commit and the CPU the task ran on.
    pub stamp: super::table::Stamp,
    /// Why the scene failed; `None` for a scene done.
    pub error: Option<String>,
}

impl Row {
    /// The row of task `index` (`scene`) before it has run: its protocol,
    /// the published figure and the stamp of this process.
    pub fn of(scene: &Scene, index: usize) -> Self {
        Row {
            index,
            scene: scene.name.clone(),
            kind: scene.kind.name().into(),
            downscale: scene.downscale,
            split: scene.scored_split().name().into(),
            published: suite::published(scene.kind, &scene.name),
            stamp: super::table::Stamp::now(),
            ..Row::default()
        }
    }
}

/// The folder of `scene`'s task in `out`.
pub fn scene_dir(out: &Path, scene: &Scene) -> PathBuf {
    out.join("scenes").join(&scene.name)
}

/// The row a task left for `scene` in `out`, if any.
pub fn read_row(out: &Path, scene: &Scene) -> Option<CmdResult<Row>> {
    let path = scene_dir(out, scene).join(RESULT);
    let text = std::fs::read_to_string(&path).ok()?;
    Some(serde_json::from_str(&text).map_err(|e| CmdError::File { path, reason: format!("not a result: {e}") }))
}

/// Whether `scene`'s task finished without error.
pub fn done(out: &Path, scene: &Scene) -> bool {
    matches!(read_row(out, scene), Some(Ok(r)) if r.error.is_none())
}

/// Runs task `index` of `settings` into `out`: nothing if its scene is
/// done; otherwise trains (resuming), exports, scores and writes its row,
/// a failed row naming the error if any step fails (and the task fails).
pub fn run(settings: &Settings, index: usize, out: &Path, threads: usize) -> CmdResult {
    let n = settings.scenes.len();
    let scene = settings.scenes.get(index).ok_or_else(|| CmdError::Flag {
        flag: "--task",
        reason: format!("{index}: the suite {} has {n} scenes (tasks 0 to {})", settings.suite.display(), n.max(1) - 1),
    })?;
    let dir = scene_dir(out, scene);
    super::super::create_dir(&dir)?;
    let _lock = lock(&dir.join(LOCK)).map_err(|e| match e {
        Locked::Busy => CmdError::Flag {
            flag: "--task",
            reason: format!(
                "{index} (scene {}): another process is running this task in {}",
                scene.name,
                dir.display()
            ),
        },
        Locked::Failed(e) => CmdError::File {
            path: dir.join(LOCK),
            reason: format!("cannot lock: {e} (the output folder's file system must support POSIX locks, as NFS does)"),
        },
    })?;
    // from here an interrupt is counted, not an exit: the task stops at the
    // next step of training or view of scoring (loading and export run to
    // their end) and writes its row saying so
    crate::cmd::interrupt::catch();
    if done(out, scene) {
        eprintln!("task {index} (scene {}): done before, kept ({})", scene.name, dir.join(RESULT).display());
        return Ok(());
    }
    let mut row = Row::of(scene, index);
    row.threads = match threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    };
    // an earlier attempt's peak (a task resumed after an interrupt measures only its own process)
    let earlier = read_row(out, scene).and_then(Result::ok).and_then(|r| r.peak_mib);
    let result = run_scene(settings, scene, &dir, threads, &mut row);
    row.peak_mib = match (peak_mib(), earlier) {
        (Some(a), Some(b)) => Some(a.max(b)),
        (a, b) => a.or(b),
    };
    if let Err(e) = &result {
        row.error = Some(e.to_string());
    }
    let text = serde_json::to_string_pretty(&row)?;
    super::super::write_atomic(&dir.join(RESULT), text.as_bytes())?;
    result.map_err(CmdError::within(format!("scene {}", scene.name)))
}

/// Writes a failed row for task `index` (`scene`) that ended with `status`
/// without writing one itself: killed by a signal (the kernel's
/// out-of-memory killer, a crash) or a panic. A task that failed otherwise
/// wrote its own row, or had none to write (its scene locked by another
/// process).
pub fn record_crash(out: &Path, scene: &Scene, index: usize, status: std::process::ExitStatus) -> CmdResult {
    #[cfg(unix)]
    let signal = std::os::unix::process::ExitStatusExt::signal(&status);
    #[cfg(not(unix))]
    let signal: Option<i32> = None;
    let why = match (signal, status.code()) {
        (Some(9), _) => "killed (signal 9: out of memory?) before it wrote its row".to_string(),
        (Some(sig), _) => format!("killed by signal {sig} before it wrote its row"),
        (None, Some(101)) => "stopped by an internal error (a panic, printed above) before it wrote its row".into(),
        _ => return Ok(()),
    };
    let row = Row { error: Some(format!("the task {why}")), ..Row::of(scene, index) };
    let text = serde_json::to_string_pretty(&row)?;
    super::super::write_atomic(&scene_dir(out, scene).join(RESULT), text.as_bytes())
}

/// Trains, exports and scores `scene` in `dir`, filling `row`.
fn run_scene(settings: &Settings, scene: &Scene, dir: &Path, threads: usize, row: &mut Row) -> CmdResult {
    let run = dir.join("run");
    let ckpt = run.join("checkpoint.bin");
    let read_trainer = || -> CmdResult<Trainer> {
        let b = nerf_train::util::userfile::read_user_file(&ckpt, 16 << 30, "checkpoint")?;
        Trainer::from_bytes(&b).map_err(|e| CmdError::File {
            path: ckpt.clone(),
            reason: format!("{e}; remove {} to train this scene from the start", run.display()),
        })
    };
    let stopped = || {
        crate::cmd::interrupt::received().then(|| {
            CmdError::Interrupted("interrupted: the same nerf bench command (or its --task) resumes it".into())
        })
    };
    let finished = |tr: &Trainer| match (settings.iters, settings.minutes) {
        (Some(n), _) => tr.step >= n,
        (None, Some(m)) => tr.elapsed >= m * 60.0,
        _ => true,
    };
    let resume = ckpt.is_file();
    if !(resume && finished(&read_trainer()?)) {
        let mut a = train::Args::new(scene.dir.clone(), settings.minutes.unwrap_or(1.0), run.clone());
        a.minutes = settings.minutes;
        a.iters = settings.iters;
        a.capture.downscale = Some(scene.downscale);
        let preset = settings.preset.as_deref().map(|p| clap::ValueEnum::from_str(p, false));
        a.preset = preset.transpose().map_err(CmdError::Usage)?;
        a.config = settings.config.as_ref().map(|(p, _)| p.clone());
        a.seed = settings.seed;
        a.threads = threads;
        a.resume = resume;
        // a run that left no checkpoint starts over
        a.force = !resume;
        // about ten validation points per curve; a step budget gets one every
        // 2 minutes of training, as a 20-minute budget does (each point renders
        // the run's validation views, which at 1008×756 take longer than the
        // training between them would at a shorter interval)
        a.val_secs = settings.minutes.map_or(120.0, |m| (m * 6.0).max(1.0));
        let trained = train::run(a);
        if let Some(e) = stopped() {
            return Err(e);
        }
        trained?;
    }
    let tr = read_trainer()?;
    row.steps = Some(tr.step);
    row.minutes = Some(tr.elapsed / 60.0);
    row.curve = curve(&run.join("train.jsonl"));
    let f32_model = run.join("model.nerf");
    let int8_model = dir.join("model_int8.nerf");
    // an earlier attempt's export of this scene's model is replaced
    let int8 = export::Args {
        force: true,
        ..export::Args::new(f32_model.clone(), nerf_infer::Scheme::I8, int8_model.clone())
    };
    export::run(int8)?;
    let data = score::load_scored(scene)?;
    stopped().map_or(Ok(()), Err)?;
    let (w, h) = data.views.first().map(|v| (v.camera.width, v.camera.height)).unwrap_or((0, 0));
    row.size = Some((w, h));
    row.views = data.views.len();
    let f = score::score(&f32_model, &data, threads, Some(&dir.join("first_view.png")))?;
    row.curve.push((tr.elapsed / 60.0, f.psnr));
    row.f32 = Some(f);
    stopped().map_or(Ok(()), Err)?;
    row.int8 = Some(score::score(&int8_model, &data, threads, None)?);
    Ok(())
}

/// The validation PSNR logged in `log` (`train.jsonl`) against training minutes.
fn curve(log: &Path) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|v| Some((v["train_secs"].as_f64()? / 60.0, v["val_psnr"].as_f64()?)))
        .collect()
}

/// The lock file in a scene's folder: locked (a POSIX record lock, which
/// NFS passes to its server, so tasks on other machines see it) while a
/// task works in the folder, released when the task ends however it ends.
const LOCK: &str = ".lock";

/// Why a lock was not taken.
enum Locked {
    /// Another process holds it.
    Busy,
    /// The file could not be opened or locked.
    Failed(std::io::Error),
}

/// Takes the exclusive lock on `path` (created if missing) for as long as
/// the returned file is open.
fn lock(path: &Path) -> Result<std::fs::File, Locked> {
    let f = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .map_err(Locked::Failed)?;
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: a zeroed flock is a valid value; its fields are set below.
        let mut fl: libc::flock = unsafe { std::mem::zeroed() };
        fl.l_type = libc::F_WRLCK as _;
        fl.l_whence = libc::SEEK_SET as _;
        // SAFETY: fcntl on a file descriptor this function owns, with a flock it owns; no memory is shared.
        if unsafe { libc::fcntl(f.as_raw_fd(), libc::F_SETLK, &fl) } != 0 {
            let e = std::io::Error::last_os_error();
            let busy = matches!(e.raw_os_error(), Some(libc::EAGAIN) | Some(libc::EACCES));
            return Err(if busy { Locked::Busy } else { Locked::Failed(e) });
        }
    }
    Ok(f)
}

/// This process's peak resident memory so far, MiB.
fn peak_mib() -> Option<f64> {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: getrusage writes into the struct it is given; a zeroed rusage is a valid value.
        let mut u: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: as above; RUSAGE_SELF names this process.
        if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) } == 0 {
            // kilobytes on Linux
            return Some(u.ru_maxrss as f64 / 1024.0);
        }
    }
    None
}
