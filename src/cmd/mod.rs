//! One module per subcommand, and the helpers they share.

pub mod demo;
pub mod eval;
pub mod export;
pub mod fit;
pub mod info;
pub mod render;
pub mod runlog;
pub mod scene;
pub mod tradeoff;
pub mod train;

use nerf_train::dataset::{self, Dataset, Format, LoadOptions, Split};
use std::path::Path;

/// A command's failure: one line for the user.
pub type CmdResult = Result<(), String>;

/// `--format` values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum FormatArg {
    /// Detect from the files present.
    Auto,
    /// transforms_{train,val,test}.json
    Blender,
    /// poses_bounds.npy + images/
    Llff,
    /// transforms.json (instant-ngp / nerfstudio)
    Ngp,
}

impl From<FormatArg> for Format {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Auto => Format::Auto,
            FormatArg::Blender => Format::Blender,
            FormatArg::Llff => Format::Llff,
            FormatArg::Ngp => Format::Ngp,
        }
    }
}

/// `--split` values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum SplitArg {
    /// Training views.
    Train,
    /// Validation views.
    Val,
    /// Test views.
    Test,
}

impl From<SplitArg> for Split {
    fn from(s: SplitArg) -> Self {
        match s {
            SplitArg::Train => Split::Train,
            SplitArg::Val => Split::Val,
            SplitArg::Test => Split::Test,
        }
    }
}

/// Loads a split, mapping errors to one line; `holdout` is LLFF's
/// `--llffhold` (every `holdout`-th image is a test/val view).
pub fn load_split(
    dir: &Path,
    split: Split,
    format: FormatArg,
    downscale: u32,
    holdout: usize,
) -> Result<Dataset, String> {
    if holdout == 0 {
        return Err("--llffhold must be at least 1".into());
    }
    dataset::load(dir, split, LoadOptions { format: format.into(), downscale, holdout }).map_err(|e| e.to_string())
}

/// Reads a model file into memory.
pub fn read_model(path: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))
}

/// Decodes a model, naming the file on failure.
pub fn decode<'a>(path: &Path, bytes: &'a [u8]) -> Result<nerf_infer::Model<'a>, String> {
    nerf_infer::Model::from_bytes(bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// Writes `bytes` to `path` atomically: a temporary file in the same
/// directory, then a rename, so a failure never leaves a partial file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    nerf_train::atomic::write(path, bytes).map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

/// Creates an output directory, naming it on failure.
pub fn create_dir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: cannot create directory: {e}", dir.display()))
}

/// Runs `f` on a rayon pool of `threads` threads (0 = all cores).
pub fn with_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T, String> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| format!("thread pool: {e}"))?;
    Ok(pool.install(f))
}

/// A progress bar with the project's style.
pub fn progress(len: u64, template: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(indicatif::ProgressStyle::with_template(template).expect("valid template").progress_chars("=> "));
    pb
}
