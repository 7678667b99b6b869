//! One module per subcommand, and the helpers they share.

pub mod bench;
pub mod capture;
pub mod demo;
pub mod error;
pub mod eval;
pub mod export;
pub mod fit;
pub mod info;
pub mod interrupt;
pub mod mesh;
pub mod outdir;
pub mod render;
pub mod runlog;
pub mod scene;
pub mod tradeoff;
pub mod train;
pub mod web;

use error::OutOfRange;
pub use error::{CmdError, CmdResult};
use nerf_infer::format::Framing;
use nerf_train::dataset::{self, Dataset, Format, LoadOptions, SceneKind, Split};
pub use nerf_train::export::ActBits;
use std::path::{Path, PathBuf};

/// A clap value parser for numbers in `lo..=hi`: anything else (not a
/// number, NaN, out of range) is refused at parse time with the range in
/// the message, which clap prefixes with the flag.
pub fn num_in<T>(lo: T, hi: T) -> impl Fn(&str) -> Result<T, OutOfRange> + Clone + Send + Sync + 'static
where
    T: std::str::FromStr + PartialOrd + std::fmt::Display + Copy + Send + Sync + 'static,
{
    move |s: &str| {
        let range = || OutOfRange { lo: lo.to_string(), hi: hi.to_string() };
        let v: T = s.trim().parse().map_err(|_| range())?;
        // NaN compares false both ways and is refused here
        if v >= lo && v <= hi {
            Ok(v)
        } else {
            Err(range())
        }
    }
}

/// `--table-bits` of `nerf export`: bits per value of the feature table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TableBits {
    /// i16 (every integer model's table unless told otherwise).
    #[value(name = "16")]
    T16,
    /// 8-bit indices into a codebook of 256 i16 values per level (format version 7).
    #[value(name = "8")]
    T8,
    /// 4-bit indices, two per byte, into a codebook of 16 i16 values per level (format version 7).
    #[value(name = "4")]
    T4,
}

impl TableBits {
    /// Bits per value.
    pub fn bits(self) -> u8 {
        match self {
            TableBits::T16 => 16,
            TableBits::T8 => 8,
            TableBits::T4 => 4,
        }
    }
}

/// `--bits` of the commands that score a fixed-point model: `16` or `8`,
/// the integer [`Scheme`](nerf_infer::Scheme)s.
pub fn fixed_scheme() -> impl clap::builder::TypedValueParser<Value = nerf_infer::Scheme> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(["16", "8"]).map(|s| {
        if s == "16" {
            nerf_infer::Scheme::I16
        } else {
            nerf_infer::Scheme::I8
        }
    })
}

/// How a dataset is read and, for a real capture (LLFF, COLMAP,
/// instant-ngp), how it becomes a scene: the flags every command that loads
/// a dataset shares. A model trained on such a capture records the last
/// three; `eval`, `render` and `tradeoff` take the model's where a flag is
/// not given.
#[derive(clap::Args, Clone, Copy, Debug, Default)]
pub struct CaptureArgs {
    /// Dataset layout.
    #[arg(long, value_enum, default_value_t = Format::Auto)]
    pub format: Format,
    /// Downscale images by this integer factor (area averaging; an LLFF capture's images_N/ copy is read if it
    /// ships one) [default: 1 to train; with a model: the one it was trained at].
    #[arg(long, value_name = "1..=64", value_parser = num_in(1u32, 64))]
    pub downscale: Option<u32>,
    /// Hold-out of LLFF, COLMAP and instant-ngp captures: every N-th image is a test/val view [default: 8; with a
    /// model: the one it was trained with].
    #[arg(long, value_name = "1..=100000", value_parser = num_in(1usize, 100_000))]
    pub llffhold: Option<usize>,
    /// Scene treatment of LLFF, COLMAP and instant-ngp captures: `auto` (from the cameras and points), `object` (a box
    /// around what the cameras look at), `forward` (NDC, as LLFF), `unbounded` (bounds holding the object and
    /// the cameras, the surroundings in the space beyond them, contracted) [default: auto; with a model: the one it was trained
    /// with].
    #[arg(long, value_enum)]
    pub scene: Option<SceneKind>,
    /// Treat every photo as an ideal pinhole: ignore the lens distortion the capture gives (with a model trained
    /// so: implied).
    #[arg(long)]
    pub ignore_distortion: bool,
    /// Resample each distorted photo once at load to the pinhole photo of the same intrinsics (bilinear, edges
    /// repeated, as COLMAP's image_undistorter) instead of bending its rays through the lens.
    #[arg(long, conflicts_with = "ignore_distortion")]
    pub undistort: bool,
    /// COLMAP captures with several reconstructions (sparse/0, sparse/1, …): load sparse/N [default: the one
    /// that registers the most images].
    #[arg(long, value_name = "N")]
    pub sparse_model: Option<u32>,
}

/// The hold-out `--llffhold` defaults to.
const DEFAULT_HOLDOUT: usize = 8;

impl CaptureArgs {
    /// The flags as a run's checkpoint records them (`--resume` compares them).
    pub fn describe(&self) -> String {
        format!(
            "--llffhold {} CaptureArgs {{ scene: {:?}, ignore_distortion: {}{}{} }}",
            self.llffhold.unwrap_or(DEFAULT_HOLDOUT),
            self.scene.unwrap_or_default(),
            self.ignore_distortion,
            // absent from runs made before the flag, so that they resume
            if self.undistort { ", undistort: true" } else { "" },
            self.sparse_model.map(|n| format!(", sparse_model: {n}")).unwrap_or_default()
        )
    }

    /// These flags completed from what `model` (read from `path`) records of
    /// its training capture: the hold-out, the scene treatment and the lens
    /// where not given. A `--llffhold` other than the model's is refused: the
    /// held-out views would include views it was trained on.
    pub fn for_model(self, model: &nerf_infer::Model<'_>, path: &Path) -> CmdResult<Self> {
        let Some(c) = model.capture else { return Ok(self) };
        if let Some(h) = self.llffhold.filter(|&h| h != c.holdout as usize) {
            return Err(CmdError::File {
                path: path.to_path_buf(),
                reason: format!(
                    "the model was trained without every {}-th view (--llffhold {}); --llffhold {h} would score views \
                     it was trained on: leave --llffhold out",
                    c.holdout, c.holdout
                ),
            });
        }
        if self.undistort && !c.lens {
            return Err(CmdError::File {
                path: path.to_path_buf(),
                reason: "--undistort: the model was trained with --ignore-distortion (its photos taken as pinholes), \
                         so there is no lens to undo; leave --undistort out"
                    .into(),
            });
        }
        let scene = match c.framing {
            Framing::Files => SceneKind::Auto,
            Framing::Object => SceneKind::Object,
            Framing::Forward => SceneKind::Forward,
            Framing::Unbounded => SceneKind::Unbounded,
        };
        Ok(Self {
            llffhold: Some(c.holdout as usize),
            scene: self.scene.or(Some(scene)),
            ignore_distortion: self.ignore_distortion || !c.lens,
            ..self
        })
    }

    /// `--downscale`, or the one `model` was trained at.
    pub fn downscale_for(&self, model: &nerf_infer::Model<'_>) -> u32 {
        self.downscale.unwrap_or(model.meta.train_downscale.max(1) as u32)
    }
}

/// Loads a split, printing the loader's notes (skipped frames) as
/// warnings.
pub fn load_split(dir: &Path, split: Split, downscale: u32, capture: CaptureArgs) -> CmdResult<Dataset> {
    let holdout = capture.llffhold.unwrap_or(DEFAULT_HOLDOUT);
    if holdout == 0 {
        return Err(CmdError::Flag { flag: "--llffhold", reason: "must be at least 1".into() });
    }
    let opts = LoadOptions {
        format: capture.format,
        downscale,
        holdout,
        scene: capture.scene.unwrap_or_default(),
        lens: !capture.ignore_distortion,
        undistort: capture.undistort,
        sparse_model: capture.sparse_model,
    };
    let data = dataset::load(dir, split, opts)?;
    for n in &data.notes {
        eprintln!("warning: {n}");
    }
    Ok(data)
}

/// Refuses views loaded in another frame than the model's: a capture
/// loaded forward-facing (NDC) for a model trained looking inward, or the
/// other way round (`--scene` differs from the training run's). Warns when
/// the capture, split as the model's was, holds other views than the
/// capture it was trained on (held-out scores may then include views it
/// saw in training).
pub fn same_frame(data: &Dataset, model: &nerf_infer::Model<'_>, model_path: &Path) -> CmdResult {
    if let (Some(d), Some(m)) = (data.capture, model.capture) {
        if d.holdout == m.holdout && (d.views, d.held_out_crc) != (m.views, m.held_out_crc) {
            eprintln!(
                "warning: {}: trained on a capture of {} views; this one has {}{}: its held-out views are not the \
                 model's",
                model_path.display(),
                m.views,
                d.views,
                if d.views == m.views { " with other held-out images" } else { "" }
            );
        } else if d.views != m.views {
            // split otherwise (a trajectory loads every view): the counts still tell another capture
            eprintln!(
                "warning: {}: trained on a capture of {} views; this one has {}: not the capture the model was \
                 trained on",
                model_path.display(),
                m.views,
                d.views
            );
        }
    }
    let (d, m) = (data.scene.ndc.is_some(), model.scene.ndc.is_some());
    if d != m {
        let kind = |ndc: bool| if ndc { "forward-facing (NDC)" } else { "inward-looking" };
        return Err(CmdError::File {
            path: model_path.to_path_buf(),
            reason: format!(
                "the model is {} but the dataset loads as {}; give the --scene the model was trained with",
                kind(m),
                kind(d)
            ),
        });
    }
    Ok(())
}

/// Reads a model file into memory.
pub fn read_model(path: &Path) -> CmdResult<Vec<u8>> {
    // the header's payload length is a u32
    let max = nerf_infer::format::HEADER_LEN as u64 + u32::MAX as u64;
    Ok(nerf_train::util::userfile::read_user_file(path, max, "model file")?)
}

/// Decodes a model, naming the file on failure.
pub fn decode<'a>(path: &Path, bytes: &'a [u8]) -> CmdResult<nerf_infer::Model<'a>> {
    nerf_infer::Model::from_bytes(bytes).map_err(CmdError::file(path))
}

/// Writes `bytes` to `path` atomically: a temporary file in the same
/// directory, then a rename, so a failure never leaves a partial file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> CmdResult {
    nerf_train::util::atomic::write(path, bytes).map_err(CmdError::io(path, "cannot write"))
}

/// `path` made absolute with its symbolic links resolved, as far as it
/// exists (the part that does not exist yet appended as given).
fn resolved(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut head = abs.as_path();
    let mut tail = Vec::new();
    loop {
        if let Ok(c) = head.canonicalize() {
            return tail.iter().rev().fold(c, |p, t| p.join(t));
        }
        match (head.parent(), head.file_name()) {
            (Some(p), Some(n)) => {
                tail.push(n.to_os_string());
                head = p;
            }
            _ => return abs,
        }
    }
}

/// Refuses an output (`flag`'s value `out`) that lies inside the dataset
/// folder `data` or is the folder itself: outputs never go among the
/// inputs, whose images they could replace.
pub fn refuse_inside(out: &Path, flag: &'static str, data: &Path) -> CmdResult {
    let (o, d) = (resolved(out), resolved(data));
    if o.starts_with(&d) {
        return Err(CmdError::Flag {
            flag,
            reason: format!(
                "{}: inside the dataset folder {}; choose a folder outside it (outputs never go among the inputs)",
                out.display(),
                data.display()
            ),
        });
    }
    Ok(())
}

/// Refuses to write the output `out` (`flag`'s value) over the input file `input`.
pub fn refuse_same_file(out: &Path, flag: &'static str, input: &Path) -> CmdResult {
    if resolved(out) == resolved(input) {
        return Err(CmdError::Flag {
            flag,
            reason: format!("{}: is the input file; write to another file", out.display()),
        });
    }
    Ok(())
}

/// Holds an exclusive lock on the run folder `dir` itself (flock on the
/// directory: no file is created, and the lock goes when the process
/// ends, however it ends) so that two runs never write one folder; fails,
/// naming the folder, if another process holds it.
pub fn lock_run_dir(dir: &Path) -> CmdResult<std::fs::File> {
    let f = std::fs::File::open(dir).map_err(CmdError::io(dir, "cannot open the folder to lock it"))?;
    #[cfg(unix)]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: flock on a file descriptor this function owns; no memory is shared.
        let r = unsafe { libc::flock(f.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) };
        if r != 0 {
            return Err(CmdError::File {
                path: dir.to_path_buf(),
                reason: "another process is using this folder".into(),
            });
        }
    }
    Ok(f)
}

/// `p` as a POSIX shell word, for the commands printed as hints: left as
/// it is when it holds only characters a shell reads literally, else in
/// single quotes (a `'` inside becomes `'\''`).
pub fn shell_quote(p: &Path) -> String {
    let s = p.to_string_lossy();
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-./=:,+@%".contains(c);
    if !s.is_empty() && s.chars().all(plain) {
        s.into_owned()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// Creates an output directory, naming it on failure.
pub fn create_dir(dir: &Path) -> CmdResult {
    std::fs::create_dir_all(dir).map_err(CmdError::io(dir, "cannot create directory"))
}

/// Runs `f` on a rayon pool of `threads` threads (0 = all cores).
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> CmdResult<T> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(CmdError::within("thread pool"))?;
    Ok(pool.install(f))
}

/// A progress bar with the project's style.
pub fn progress(len: u64, template: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(indicatif::ProgressStyle::with_template(template).expect("valid template").progress_chars("=> "));
    pb
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The arguments `argv` parses to.
    fn parsed<A: clap::Args + clap::FromArgMatches>(argv: &[&str]) -> A {
        let m = A::augment_args(clap::Command::new("nerf")).get_matches_from(argv);
        A::from_arg_matches(&m).unwrap()
    }

    /// What one command gives another (`Args::new` and its kin) is what the
    /// command line gives with only the required arguments: the defaults
    /// live in one place.
    #[test]
    fn constructors_match_the_parsed_defaults() {
        fn same(a: impl std::fmt::Debug, b: impl std::fmt::Debug) {
            assert_eq!(format!("{a:?}"), format!("{b:?}"));
        }
        same(parsed::<eval::Args>(&["eval", "m.nerf", "--data", "d"]), eval::Args::new("m.nerf".into(), "d".into()));
        let train = parsed::<train::Args>(&["train", "--data", "d", "--minutes", "2", "--out", "o"]);
        same(train, train::Args::new("d".into(), 2.0, "o".into()));
        let export = parsed::<export::Args>(&["export", "m.nerf", "--bits", "8", "--out", "o.nerf"]);
        same(export, export::Args::new("m.nerf".into(), nerf_infer::Scheme::I8, "o.nerf".into()));
        same(parsed::<scene::Args>(&["scene", "--out", "o"]), scene::Args::new("o".into()));
        let render = parsed::<render::Args>(&["render", "m.nerf", "--orbit", "24", "--out", "o"]);
        same(render, render::Args::orbit("m.nerf".into(), 24, "o".into()));
        let tradeoff = parsed::<tradeoff::Args>(&["tradeoff", "m.nerf", "--data", "d", "--out", "o"]);
        same(tradeoff, tradeoff::Args::new("m.nerf".into(), "d".into(), "o".into()));
    }

    #[test]
    fn hints_quote_paths_a_shell_would_split_or_run() {
        let q = |p: &str| shell_quote(Path::new(p));
        assert_eq!(q("runs/lego-2.5"), "runs/lego-2.5");
        assert_eq!(q("my runs/a"), "'my runs/a'");
        assert_eq!(q("a;rm -rf x"), "'a;rm -rf x'");
        assert_eq!(q("it's"), "'it'\\''s'");
        assert_eq!(q("$HOME"), "'$HOME'");
        assert_eq!(q(""), "''");
    }
}
