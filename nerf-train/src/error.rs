//! The crate's one error type, [`Error`]: its variant says which stage
//! failed and its message names what is at fault (the file, the field, the
//! camera) and, where there is one, what to do. A stage's own functions
//! may return the error that stage wraps ([`DataError`], [`ParseError`],
//! [`MeshError`], each converting into [`Error`] with `?`); the low-level
//! file writers (`atomic`, the COLMAP and `.npy` writers) return
//! `std::io::Result`; a caller names the file, in its stage's error or in
//! [`Error::Io`] ([`Error::io`], as the plot writer does).

use std::fmt;
use std::path::{Path, PathBuf};

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
    #[error("{0}")]
    Camera(String),
    /// A training configuration: the field and the range it must be in.
    #[error("{0}")]
    Config(String),
    /// A model that cannot be exported, quantised or narrowed as asked.
    #[error("{0}")]
    Export(String),
    /// A file a user names (a camera path, a model, a checkpoint): its
    /// size, type or content.
    #[error("{0}")]
    File(String),
    /// A training checkpoint that cannot be resumed: why.
    #[error("not a valid checkpoint: {0}")]
    Checkpoint(String),
    /// A mesh that cannot be made.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A model the renderer refuses (to write, to read or to render).
    #[error("the model: {0}")]
    Model(#[from] nerf_infer::Error),
    /// A plot that cannot be drawn.
    #[error("{0}")]
    Plot(String),
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

/// `v` as a message shows it: plain up to 10¹⁵, in exponent form for the
/// huge and the tiny (1e308 is not written out in 309 digits).
/// An `f32` is written as its own shortest form (1e30, not the nearest f64).
pub fn number<T: Into<f64> + Copy + fmt::Display + fmt::LowerExp>(v: T) -> String {
    let x: f64 = v.into();
    if x != 0.0 && x.is_finite() && !(1e-4..1e15).contains(&x.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_io_error_names_its_file_and_keeps_the_systems_reason() {
        let e = Error::io(Path::new("out/plot.png"))(std::io::Error::from(std::io::ErrorKind::PermissionDenied));
        let message = e.to_string();
        assert!(
            message.starts_with("out/plot.png: ") && message.to_lowercase().contains("permission denied"),
            "{message}"
        );
        let source = std::error::Error::source(&e).and_then(|s| s.downcast_ref::<std::io::Error>());
        assert_eq!(source.map(|s| s.kind()), Some(std::io::ErrorKind::PermissionDenied));
    }
}
