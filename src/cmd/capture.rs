//! `nerf capture`: from a folder of photos (or a video) to a capture that
//! `nerf train` reads, through the installed COLMAP run on the CPU without
//! a display: feature extraction, matching (exhaustive for small captures,
//! sequential for long ones or video frames, vocabulary tree when a tree
//! is given) and the mapper. The reconstruction registering the most
//! photos is reported with its registered count and mean reprojection
//! error. The user's photos are copied, never touched; the capture is
//! assembled in a sibling folder and renamed into place only once COLMAP
//! has succeeded.

use super::{lock_run_dir, num_in, refuse_inside, CmdResult};
use nerf_train::dataset::colmap_io::read_model;
use nerf_train::dataset::reconstructions::{choose_model, numbered_models, registered_images};
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// Captures of up to this many photos are matched exhaustively (every pair).
const EXHAUSTIVE_UP_TO: usize = 300;

/// Arguments of `nerf capture`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("input").required(true).args(["photos", "video"])))]
pub struct Args {
    /// Folder of photos (JPEG or PNG; subfolders are not read). They are copied into OUT/images/.
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
            return Err(format!("--photos {}: not a folder of photos", p.display()));
        }
        refuse_inside(&a.out, "--out", p)?;
    } else if !input.is_file() {
        return Err(format!("--video {}: no such file", input.display()));
    }
    if a.matcher == Matcher::VocabTree && a.vocab_tree.is_none() {
        return Err("--matcher vocab-tree: give the tree file with --vocab-tree FILE".into());
    }
    if let Some(t) = a.vocab_tree.as_ref().filter(|t| !t.is_file()) {
        return Err(format!("--vocab-tree {}: no such file", t.display()));
    }
    if a.out.exists() && std::fs::read_dir(&a.out).map(|mut d| d.next().is_some()).unwrap_or(true) {
        return Err(format!("--out {}: exists and is not empty; name a new folder", a.out.display()));
    }
    let colmap = find_program(&a.colmap, "--colmap", "colmap")?;
    let ffmpeg = match a.video {
        Some(_) => Some(find_program(&a.ffmpeg, "--ffmpeg", "ffmpeg")?),
        None => None,
    };
    // assembled beside OUT, renamed into place at the end
    let name = a.out.file_name().ok_or_else(|| format!("--out {}: not a folder name", a.out.display()))?;
    let parent = a.out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    super::create_dir(parent)?;
    // this process's own work folder: another capture into the same OUT never shares it
    let work = parent.join(format!(".{}.partial-{}", name.to_string_lossy(), std::process::id()));
    if work.exists() {
        return Err(format!(
            "{}: exists (left by an earlier capture); remove it or name another --out",
            work.display()
        ));
    }
    super::create_dir(&work.join("images"))?;
    let _lock = lock_run_dir(&work)?;
    let log_path = work.join("colmap.log");
    let mut log =
        std::fs::File::create(&log_path).map_err(|e| format!("{}: cannot create: {e}", log_path.display()))?;
    let fail =
        |e: String| format!("{e} (the partial capture is in {}; COLMAP's log: {})", work.display(), log_path.display());
    let t0 = Instant::now();
    let mut times = Vec::new();

    let stage = Instant::now();
    let (total, from_video) = match (&a.photos, &ffmpeg) {
        (Some(p), _) => (copy_photos(p, &work.join("images"))?, false),
        (None, Some(ff)) => {
            let pattern = work.join("images").join("frame_%05d.jpg");
            let args = [
                "-hide_banner".into(),
                "-i".into(),
                input.as_os_str().to_owned(),
                "-vf".into(),
                format!("fps={}", a.fps).into(),
                "-qscale:v".into(),
                "2".into(),
                pattern.into_os_string(),
            ];
            run_stage(ff, &args, "frames", &mut log).map_err(fail)?;
            (count_photos(&work.join("images")), true)
        }
        (None, None) => unreachable!("ffmpeg is found for --video"),
    };
    if total < 3 {
        return Err(fail(format!("{}: {total} photos; COLMAP needs at least 3 (50 to 200 is usual)", input.display())));
    }
    times.push(("photos", stage.elapsed().as_secs_f64()));
    eprintln!("{total} photos in {}", work.join("images").display());

    let db = work.join("database.db");
    let images = work.join("images");
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
    run_stage(&colmap, &extract, "features", &mut log).map_err(fail)?;
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
    run_stage(&colmap, &matching, &format!("matching ({})", matching[0].to_string_lossy()), &mut log).map_err(fail)?;
    times.push(("matching", stage.elapsed().as_secs_f64()));

    let stage = Instant::now();
    let sparse = work.join("sparse");
    super::create_dir(&sparse)?;
    let mapper = [
        os("mapper"),
        os("--database_path"),
        db.into(),
        os("--image_path"),
        images.into(),
        os("--output_path"),
        sparse.into(),
    ];
    run_stage(&colmap, &mapper, "mapper", &mut log).map_err(|e| {
        fail(format!(
            "{e}; COLMAP found no model: photos need more overlap (each sharing about two thirds of its view with \
             its neighbours) and texture"
        ))
    })?;
    times.push(("mapper", stage.elapsed().as_secs_f64()));

    // every reconstruction, the one chosen first
    let models = numbered_models(&work);
    if models.is_empty() {
        return Err(fail("COLMAP registered no photos: too little overlap or texture between them".into()));
    }
    let (chosen, _) = choose_model(&work, None).map_err(|e| fail(e.to_string()))?;
    let mut lines = Vec::new();
    for (k, dir) in &models {
        let n = registered_images(dir).map_err(|e| fail(e.to_string()))?;
        let err = mean_reprojection_error(dir).map_err(fail)?;
        let mark = if *dir == chosen { " (nerf train loads this one)" } else { "" };
        lines
            .push(format!("  sparse/{k}: {n} of {total} photos registered, mean reprojection error {err:.3} px{mark}"));
    }
    drop(log);
    std::fs::rename(&work, &a.out).map_err(|e| fail(format!("cannot rename to {}: {e}", a.out.display())))?;
    eprintln!("{}: {} reconstruction(s)", a.out.display(), models.len());
    for l in lines {
        eprintln!("{l}");
    }
    let t: Vec<String> = times.iter().map(|(s, t)| format!("{s} {t:.1} s")).collect();
    eprintln!("time: {} (total {:.1} s)", t.join(", "), t0.elapsed().as_secs_f64());
    eprintln!("next: nerf train --data {} --downscale 8 --minutes 5 --out run", a.out.display());
    Ok(())
}

/// `program` if it runs (`--help` or `-version` exits), else an error
/// naming `flag` and how to install `package`.
fn find_program(program: &Path, flag: &str, package: &str) -> Result<PathBuf, String> {
    let probe = if package == "ffmpeg" { "-version" } else { "help" };
    match Command::new(program).arg(probe).stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::null()).status() {
        Ok(_) => Ok(program.to_path_buf()),
        Err(e) => Err(format!(
            "{flag} {}: cannot run it ({e}); install {package} (Debian/Ubuntu: apt-get install {package}; macOS: brew \
             install {package}) or give its path with {flag}",
            program.display()
        )),
    }
}

/// Whether `p` names a JPEG or PNG file.
fn is_photo(p: &Path) -> bool {
    matches!(
        p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(),
        Some("jpg" | "jpeg" | "png")
    ) && p.is_file()
}

/// How many photos `dir` holds.
fn count_photos(dir: &Path) -> usize {
    std::fs::read_dir(dir).map(|d| d.filter_map(|e| e.ok()).filter(|e| is_photo(&e.path())).count()).unwrap_or(0)
}

/// Copies the photos of `from` into `to`; returns how many.
fn copy_photos(from: &Path, to: &Path) -> Result<usize, String> {
    let entries = std::fs::read_dir(from).map_err(|e| format!("--photos {}: cannot list: {e}", from.display()))?;
    let mut n = 0;
    for e in entries.filter_map(|e| e.ok()) {
        let p = e.path();
        if is_photo(&p) {
            std::fs::copy(&p, to.join(e.file_name())).map_err(|err| format!("{}: cannot copy: {err}", p.display()))?;
            n += 1;
        }
    }
    Ok(n)
}

/// The mean reprojection error (pixels) of the model in `dir`: its points'
/// errors weighted by how many photos see each (COLMAP's mean over
/// observations).
fn mean_reprojection_error(dir: &Path) -> Result<f64, String> {
    let rec = read_model(dir).map_err(|e| e.to_string())?;
    let (sum, n) =
        rec.points.iter().fold((0.0, 0.0), |(s, n), p| (s + p.error * p.track_len as f64, n + p.track_len as f64));
    Ok(if n > 0.0 { sum / n } else { f64::NAN })
}

/// Runs `program args` headless (no display: Qt's offscreen platform),
/// its output appended to `log`, with a spinner showing the stage, its
/// time and the program's last progress line; an error names the stage
/// and the program's last lines.
fn run_stage(program: &Path, args: &[std::ffi::OsString], stage: &str, log: &mut std::fs::File) -> CmdResult {
    use std::io::Write;
    let _ = writeln!(
        log,
        "== {stage}: {} {}",
        program.display(),
        args.iter().map(|a| a.to_string_lossy()).collect::<Vec<_>>().join(" ")
    );
    let mut child = Command::new(program)
        .args(args)
        .env("QT_QPA_PLATFORM", "offscreen")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("{stage}: cannot run {}: {e}", program.display()))?;
    let pb = indicatif::ProgressBar::new_spinner();
    pb.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {prefix} [{elapsed}] {wide_msg}").expect("template"),
    );
    pb.set_prefix(stage.to_string());
    pb.enable_steady_tick(std::time::Duration::from_millis(200));
    // both streams into one channel of lines: COLMAP logs to stderr, ffmpeg too
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let pipe = |r: Box<dyn Read + Send>, tx: std::sync::mpsc::Sender<String>| {
        std::thread::spawn(move || {
            for line in BufReader::new(r).split(b'\n').map_while(Result::ok) {
                // ffmpeg ends its progress lines with \r
                for part in String::from_utf8_lossy(&line).split('\r') {
                    let _ = tx.send(part.to_string());
                }
            }
        })
    };
    let a = pipe(Box::new(child.stdout.take().expect("piped")), tx.clone());
    let b = pipe(Box::new(child.stderr.take().expect("piped")), tx);
    let mut tail: std::collections::VecDeque<String> = Default::default();
    for line in rx {
        let _ = writeln!(log, "{line}");
        let t = line.trim();
        if t.contains('[') && t.contains('/') || t.starts_with("Registering image") || t.starts_with("frame=") {
            pb.set_message(t.chars().take(80).collect::<String>());
        }
        if !t.is_empty() {
            tail.push_back(t.to_string());
            if tail.len() > 4 {
                tail.pop_front();
            }
        }
    }
    let _ = (a.join(), b.join());
    let status = child.wait().map_err(|e| format!("{stage}: {e}"))?;
    pb.finish_and_clear();
    if !status.success() {
        let last: Vec<String> = tail.into_iter().collect();
        return Err(format!("{stage}: {} failed ({status}); its last lines: {}", program.display(), last.join(" | ")));
    }
    eprintln!("{stage}: done in {:.1} s", pb.elapsed().as_secs_f64());
    Ok(())
}
