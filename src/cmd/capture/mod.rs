//! `nerf capture`: from a folder of photos (or a video) to a capture that
//! `nerf train` reads, through the installed COLMAP run on the CPU without
//! a display: feature extraction, matching (exhaustive for small captures,
//! sequential for long ones or video frames, vocabulary tree when a tree
//! is given) and the mapper. The reconstruction registering the most
//! photos is reported with its registered count and mean reprojection
//! error. The user's photos are copied, never touched; the capture is
//! assembled in a sibling folder and renamed into place only once COLMAP
//! has succeeded. `--out` is locked while the capture is made; a failed
//! or interrupted capture leaves nothing behind but COLMAP's log, in the
//! system's temporary folder.

use super::{lock_run_dir, num_in, refuse_inside, shell_quote, CmdError, CmdResult};
use nerf_train::dataset::colmap_io::read_model;
use nerf_train::dataset::reconstructions::{choose_model, numbered_models, registered_images};
use std::path::{Path, PathBuf};
use std::time::Instant;

mod photos;
mod stage;

/// Captures of up to this many photos are matched exhaustively (every pair).
const EXHAUSTIVE_UP_TO: usize = 300;

/// Arguments of `nerf capture`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["photos", "video"])))]
pub struct Args {
    /// Folder of photos (JPEG or PNG; subfolders are not read; unreadable files are named and skipped). They are
    /// copied into OUT/images/.
    #[arg(long)]
    pub(crate) photos: Option<PathBuf>,
    /// A video to take frames from with ffmpeg (see --fps).
    #[arg(long)]
    pub(crate) video: Option<PathBuf>,
    /// Frames per second of video taken.
    #[arg(long, default_value_t = 2.0, value_name = "0.01..=60", value_parser = num_in(0.01f64, 60.0))]
    pub(crate) fps: f64,
    /// Capture folder to write (must not exist, or be empty): images/, sparse/N/, database.db, colmap.log.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// COLMAP camera model shared by all photos (OPENCV: focal lengths, centre and four distortion terms).
    #[arg(long, default_value = "OPENCV", value_parser = ["SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV", "OPENCV_FISHEYE", "FULL_OPENCV"])]
    pub(crate) camera_model: String,
    /// One camera per photo instead of one for all (photos from several phones or zoom settings).
    #[arg(long)]
    pub(crate) camera_per_photo: bool,
    /// How photos are matched: `auto` (exhaustive up to 300 photos, sequential beyond and for video frames),
    /// `exhaustive`, `sequential` (each photo with its neighbours in name order), `vocab-tree` (needs --vocab-tree).
    #[arg(long, value_enum, default_value_t = Matcher::Auto)]
    pub(crate) matcher: Matcher,
    /// A COLMAP vocabulary tree file (for --matcher vocab-tree, and loop closure with sequential matching).
    #[arg(long)]
    pub(crate) vocab_tree: Option<PathBuf>,
    /// The COLMAP program.
    #[arg(long, default_value = "colmap")]
    pub(crate) colmap: PathBuf,
    /// The ffmpeg program (for --video).
    #[arg(long, default_value = "ffmpeg")]
    pub(crate) ffmpeg: PathBuf,
}

/// `--matcher` values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Matcher {
    /// Exhaustive for up to 300 photos, sequential beyond and for video frames.
    Auto,
    /// Every pair of photos.
    Exhaustive,
    /// Each photo with its neighbours in name order.
    Sequential,
    /// Each photo with its most similar ones (a vocabulary tree).
    VocabTree,
}

/// Runs `nerf capture`.
pub fn run(a: Args) -> CmdResult {
    let input = a.photos.as_ref().or(a.video.as_ref()).expect("clap requires one");
    if let Some(p) = &a.photos {
        if !p.is_dir() {
            return Err(CmdError::Flag {
                flag: "--photos",
                reason: format!("{}: not a folder of photos", p.display()),
            });
        }
        refuse_inside(&a.out, "--out", p)?;
    } else if !input.is_file() {
        return Err(CmdError::Flag { flag: "--video", reason: format!("{}: no such file", input.display()) });
    }
    if a.matcher == Matcher::VocabTree && a.vocab_tree.is_none() {
        return Err(CmdError::Flag {
            flag: "--matcher",
            reason: "vocab-tree: give the tree file with --vocab-tree FILE".into(),
        });
    }
    if let Some(t) = a.vocab_tree.as_ref().filter(|t| !t.is_file()) {
        return Err(CmdError::Flag { flag: "--vocab-tree", reason: format!("{}: no such file", t.display()) });
    }
    // absolute: the frames' stage runs in another folder
    let out = output_folder(&a.out)?;
    let colmap = stage::find_program(&a.colmap, "--colmap", "colmap")?;
    let ffmpeg = match a.video {
        Some(_) => Some(stage::find_program(&a.ffmpeg, "--ffmpeg", "ffmpeg")?),
        None => None,
    };
    let survey = match &a.photos {
        Some(p) => {
            let s = photos::survey(p, "--photos")?;
            if s.photos.len() < 3 {
                let skipped = s.skipped();
                let skipped = if skipped.is_empty() { String::new() } else { format!(" (skipped: {skipped})") };
                return Err(CmdError::Flag {
                    flag: "--photos",
                    reason: format!(
                        "{}: {} readable JPEG or PNG photos{skipped}; COLMAP needs at least 3 (50 to 200 is usual)",
                        p.display(),
                        s.photos.len()
                    ),
                });
            }
            if !a.camera_per_photo {
                s.one_size("--photos", p)?;
            }
            Some(s)
        }
        None => None,
    };
    // OUT claimed (created empty if missing, locked) while the capture is assembled beside it
    let mut partial = Partial::claim(&out)?;
    let work = partial.work.clone();
    let log_path = partial.log();
    let mut log = std::fs::File::create(&log_path).map_err(CmdError::io(&log_path, "cannot create"))?;
    let t0 = Instant::now();
    let mut times = Vec::new();

    let stage = Instant::now();
    let images = work.join("images");
    let (total, from_video) = match (&survey, &ffmpeg) {
        (Some(s), _) => {
            let skipped = s.skipped();
            if !skipped.is_empty() {
                eprintln!("skipped in {}: {skipped}", input.display());
            }
            photos::copy(s, &images).map_err(|e| partial.fail(e))?;
            (s.photos.len(), false)
        }
        (None, Some(ff)) => {
            // a pattern relative to the frames' folder: a % in --out is not ffmpeg's to read
            let args = [
                "-hide_banner".into(),
                "-i".into(),
                std::path::absolute(input).unwrap_or(input.clone()).into_os_string(),
                "-vf".into(),
                format!("fps={}", a.fps).into(),
                "-qscale:v".into(),
                "2".into(),
                "frame_%05d.jpg".into(),
            ];
            stage::run(ff, &args, Some(&images), "frames", &mut log).map_err(|e| partial.fail(e))?;
            let frames = photos::survey(&images, "frames").map(|s| s.photos.len()).unwrap_or(0);
            if frames < 3 {
                return Err(partial.fail(CmdError::File {
                    path: input.clone(),
                    reason: format!("{frames} frames; COLMAP needs at least 3 (raise --fps)"),
                }));
            }
            (frames, true)
        }
        (None, None) => unreachable!("ffmpeg is found for --video"),
    };
    times.push(("photos", stage.elapsed().as_secs_f64()));
    eprintln!("{total} photos in {}", images.display());

    let db = work.join("database.db");
    let os = |s: &str| std::ffi::OsString::from(s);
    let stage = Instant::now();
    let extract = [
        os("feature_extractor"),
        os("--database_path"),
        db.clone().into(),
        os("--image_path"),
        images.clone().into(),
        os("--ImageReader.camera_model"),
        os(&a.camera_model),
        os("--ImageReader.single_camera"),
        os(if a.camera_per_photo { "0" } else { "1" }),
        os("--SiftExtraction.use_gpu"),
        os("0"),
    ];
    let run_colmap =
        |args: &[std::ffi::OsString], name: &str, log: &mut std::fs::File| stage::run(&colmap, args, None, name, log);
    let stage_ok = |r: CmdResult, log: &std::fs::File| -> CmdResult {
        let _ = log.sync_all();
        r.map_err(|e| partial.fail(e))
    };
    stage_ok(run_colmap(&extract, "features", &mut log), &log)?;
    if std::fs::metadata(&db).map(|m| m.len() == 0).unwrap_or(true) {
        return stage_ok(
            Err(CmdError::Flag {
                flag: "--colmap",
                reason: format!(
                    "{}: feature_extractor ended well but wrote no database; is it COLMAP?",
                    a.colmap.display()
                ),
            }),
            &log,
        );
    }
    times.push(("features", stage.elapsed().as_secs_f64()));

    let stage = Instant::now();
    let matcher = match a.matcher {
        Matcher::Auto if from_video || total > EXHAUSTIVE_UP_TO => Matcher::Sequential,
        Matcher::Auto => Matcher::Exhaustive,
        m => m,
    };
    let mut matching = vec![
        os(match matcher {
            Matcher::Exhaustive | Matcher::Auto => "exhaustive_matcher",
            Matcher::Sequential => "sequential_matcher",
            Matcher::VocabTree => "vocab_tree_matcher",
        }),
        os("--database_path"),
        db.clone().into(),
        os("--SiftMatching.use_gpu"),
        os("0"),
    ];
    match (matcher, &a.vocab_tree) {
        (Matcher::VocabTree, Some(t)) => matching.extend([os("--VocabTreeMatching.vocab_tree_path"), t.into()]),
        (Matcher::Sequential, Some(t)) => matching.extend([
            os("--SequentialMatching.loop_detection"),
            os("1"),
            os("--SequentialMatching.vocab_tree_path"),
            t.into(),
        ]),
        _ => {}
    }
    let name = format!("matching ({})", matching[0].to_string_lossy());
    stage_ok(run_colmap(&matching, &name, &mut log), &log)?;
    times.push(("matching", stage.elapsed().as_secs_f64()));

    let stage = Instant::now();
    let sparse = work.join("sparse");
    stage_ok(super::create_dir(&sparse), &log)?;
    let mapper = [
        os("mapper"),
        os("--database_path"),
        db.into(),
        os("--image_path"),
        images.into(),
        os("--output_path"),
        sparse.into(),
    ];
    let mapped =
        run_colmap(&mapper, "mapper", &mut log).map_err(|e| e.noted(format!("; {}", stage::diagnose(&log_path))));
    stage_ok(mapped, &log)?;
    times.push(("mapper", stage.elapsed().as_secs_f64()));

    // every reconstruction, the one chosen first
    let models = numbered_models(&work);
    if models.is_empty() {
        let registered_none =
            CmdError::Program { stage: "COLMAP registered no photos".into(), reason: stage::diagnose(&log_path) };
        return stage_ok(Err(registered_none), &log);
    }
    let mut lines = Vec::new();
    let mut summary = || -> CmdResult {
        let (chosen, _) = choose_model(&work, None)?;
        for (k, dir) in &models {
            let n = registered_images(dir)?;
            let err = mean_reprojection_error(dir)?;
            let mark = if *dir == chosen { " (nerf train loads this one)" } else { "" };
            lines.push(format!(
                "  sparse/{k}: {n} of {total} photos registered, mean reprojection error {err:.3} px{mark}"
            ));
        }
        Ok(())
    };
    stage_ok(summary(), &log)?;
    drop(log);
    partial.finish()?;
    eprintln!("{}: {} reconstruction(s)", a.out.display(), models.len());
    for l in lines {
        eprintln!("{l}");
    }
    let t: Vec<String> = times.iter().map(|(s, t)| format!("{s} {t:.1} s")).collect();
    eprintln!("time: {} (total {:.1} s)", t.join(", "), t0.elapsed().as_secs_f64());
    eprintln!("next: nerf train --data {} --downscale 8 --minutes 5 --out run", shell_quote(&a.out));
    Ok(())
}

/// `--out` as the capture is renamed onto: a symbolic link is followed to
/// its folder (the link is kept); refused if it holds anything, or if it
/// is a link to nothing.
fn output_folder(out: &Path) -> CmdResult<PathBuf> {
    let refused = |reason: String| CmdError::Flag { flag: "--out", reason };
    let is_link = std::fs::symlink_metadata(out).map(|m| m.file_type().is_symlink()).unwrap_or(false);
    let out = if is_link {
        std::fs::canonicalize(out).map_err(|e| {
            refused(format!(
                "{}: a symbolic link to something that cannot be reached ({e}); name a folder",
                out.display()
            ))
        })?
    } else {
        std::path::absolute(out).map_err(|e| refused(format!("{}: {e}", out.display())))?
    };
    if out.exists() && !out.is_dir() {
        return Err(refused(format!("{}: exists and is not a folder; name a new folder", out.display())));
    }
    if out.exists() && std::fs::read_dir(&out).map(|mut d| d.next().is_some()).unwrap_or(true) {
        return Err(refused(format!("{}: exists and is not empty; name a new folder", out.display())));
    }
    if out.file_name().is_none() {
        return Err(refused(format!("{}: not a folder name", out.display())));
    }
    Ok(out)
}

/// A capture being assembled: `--out` claimed (created empty if missing,
/// locked), the work folder beside it. Dropped before [`Partial::finish`]
/// (an error, an interrupt), it removes the work folder and the `--out` it
/// created.
struct Partial {
    out: PathBuf,
    work: PathBuf,
    created_out: bool,
    done: bool,
    _lock: std::fs::File,
}

impl Partial {
    fn claim(out: &Path) -> CmdResult<Self> {
        let name = out.file_name().expect("output_folder checks the name").to_string_lossy().into_owned();
        let parent = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        super::create_dir(parent)?;
        let created_out = !out.exists();
        if created_out {
            std::fs::create_dir(out).map_err(|e| CmdError::Flag {
                flag: "--out",
                reason: format!("{}: cannot create: {e}", out.display()),
            })?;
        }
        let lock = lock_run_dir(out).map_err(|e| CmdError::Flag {
            flag: "--out",
            reason: format!("{e} (another nerf capture is writing it); wait for it, or name another folder"),
        });
        let lock = match lock {
            Ok(l) => l,
            Err(e) => {
                if created_out {
                    let _ = std::fs::remove_dir(out);
                }
                return Err(e);
            }
        };
        // this process's own work folder (one left by an earlier process of the same id is not this one's)
        let work = parent.join(format!(".{name}.partial-{}", std::process::id()));
        if work.exists() {
            if created_out {
                let _ = std::fs::remove_dir(out);
            }
            return Err(CmdError::File { path: work, reason: "exists; remove it or name another --out".into() });
        }
        let p = Self { out: out.to_path_buf(), work, created_out, done: false, _lock: lock };
        // every interrupt stops the running stage, which the stage loop sees within 200 ms: never an exit
        // that would leave the work folder and COLMAP running
        super::interrupt::catch_every();
        super::create_dir(&p.work.join("images"))?;
        Ok(p)
    }

    /// COLMAP's log, in the work folder.
    fn log(&self) -> PathBuf {
        self.work.join("colmap.log")
    }

    /// `e`, with where COLMAP's log is kept: a new file in the system's
    /// temporary folder (the work folder goes with the failure).
    fn fail(&self, e: CmdError) -> CmdError {
        let kept = std::env::temp_dir().join(format!(
            "nerf-capture-{}-{}.log",
            std::process::id(),
            std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos())
        ));
        // a new file only (never through a link someone left there)
        let copied = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&kept)
            .and_then(|mut to| std::io::copy(&mut std::fs::File::open(self.log())?, &mut to));
        match copied {
            Ok(_) => e.noted(format!(" (nothing was written to --out; COLMAP's log: {})", kept.display())),
            Err(_) => e.noted(" (nothing was written to --out)"),
        }
    }

    /// Renames the work folder onto `--out`; if that fails, the capture is
    /// kept in the work folder, and the error says so.
    fn finish(&mut self) -> CmdResult {
        let renamed = std::fs::rename(&self.work, &self.out);
        self.done = true;
        let part = format!("cannot rename the finished capture onto {}", self.out.display());
        renamed.map_err(|e| CmdError::within(part)(e).noted(format!("; it is kept in {}", self.work.display())))
    }
}

impl Drop for Partial {
    fn drop(&mut self) {
        if self.done {
            return;
        }
        let _ = std::fs::remove_dir_all(&self.work);
        if self.created_out {
            let _ = std::fs::remove_dir(&self.out);
        }
    }
}

/// The mean reprojection error (pixels) of the model in `dir`: its points'
/// errors weighted by how many photos see each (COLMAP's mean over
/// observations).
fn mean_reprojection_error(dir: &Path) -> CmdResult<f64> {
    let rec = read_model(dir)?;
    let (sum, n) =
        rec.points.iter().fold((0.0, 0.0), |(s, n), p| (s + p.error * p.track_len as f64, n + p.track_len as f64));
    Ok(if n > 0.0 { sum / n } else { f64::NAN })
}
