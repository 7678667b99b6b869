//! The crate's one error type, [`Error`]: its variant says which stage
//! failed and holds that stage's typed cause, whose message names what is
//! at fault (the file, the field, the camera) and, where there is one,
//! what to do. A stage's own functions may return the error that stage
//! wraps ([`DataError`], [`ParseError`], [`MeshError`], [`ConfigError`],
//! [`CameraError`], [`ExportError`], [`FileError`], [`CheckpointError`],
//! [`PlotError`], each converting into [`Error`] with `?`); the low-level
//! file writers (`atomic`, the COLMAP and `.npy` writers) return
//! `std::io::Result`; a caller names the file, in its stage's error or in
//! [`Error::Io`] ([`Error::io`], as the plot writer does). Where the cause
//! is another crate's error (an I/O error, serde_json's, postcard's,
//! plotters', `nerf-infer`'s), the typed error holds it as its source.

use std::fmt;
use std::path::{Path, PathBuf};

mod camera;
mod checkpoint;
mod config;
mod export;
mod file;
mod plot;
#[cfg(test)]
mod tests;

pub use camera::*;
pub use checkpoint::*;
pub use config::*;
pub use export::*;
pub use file::*;
pub use plot::*;

/// Everything that can go wrong in `nerf-train`, by stage.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A dataset: a file or folder that cannot be loaded as one.
    #[error(transparent)]
    Data(#[from] DataError),
    /// A COLMAP model file.
    #[error(transparent)]
    Colmap(#[from] ParseError),
    /// A capture's cameras: a camera model or rays training cannot use.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// A training configuration: the field and the range it must be in.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A model that cannot be exported, quantised or narrowed as asked.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// A file a user names (a camera path, a model, a checkpoint): its
    /// size, type or content.
    #[error(transparent)]
    File(#[from] FileError),
    /// A training checkpoint that cannot be resumed: why.
    #[error("not a valid checkpoint: {0}")]
    Checkpoint(#[from] CheckpointError),
    /// A mesh that cannot be made.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A model the renderer refuses (to write, to read or to render).
    #[error("the model: {0}")]
    Model(#[from] nerf_infer::Error),
    /// A plot that cannot be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A file that cannot be read or written: its path and the system's
    /// reason.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system reported.
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// For `map_err` on an I/O result about `path`: the error as
    /// [`Error::Io`], naming the file.
    pub fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
        move |source| Error::Io { path: path.to_path_buf(), source }
    }
}

/// For callers whose errors are messages (the `nerf` command): the message.
impl From<Error> for String {
    fn from(e: Error) -> String {
        e.to_string()
    }
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// A dataset loading error: the file and what is wrong with it.
#[derive(Debug, thiserror::Error)]
#[error("{}: {msg}", path.display())]
pub struct DataError {
    /// The file (or directory) at fault.
    pub path: PathBuf,
    /// What is wrong, one line.
    pub msg: String,
}

impl DataError {
    /// An error about `path`.
    pub fn new(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Self { path: path.as_ref().to_path_buf(), msg: msg.into() }
    }
}

/// A file that cannot be read as a COLMAP model: which file and why.
#[derive(Debug, Clone, PartialEq)]
pub struct ParseError {
    /// The file at fault.
    pub path: PathBuf,
    /// What is wrong, one line.
    pub msg: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.msg)
    }
}

impl std::error::Error for ParseError {}

impl From<ParseError> for DataError {
    fn from(e: ParseError) -> Self {
        DataError::new(e.path, e.msg)
    }
}

/// Why a mesh cannot be made.
#[derive(Debug)]
pub enum MeshError {
    /// The scene is forward-facing: its bounds are in NDC, not world units.
    Ndc,
    /// An option is out of range (the message says which).
    Option(String),
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshError::Ndc => write!(
                f,
                "the model is of a forward-facing scene (NDC space), which has no bounded volume to mesh; \
                 train with --scene object or --scene unbounded"
            ),
            MeshError::Option(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for MeshError {}
