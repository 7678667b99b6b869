//! The command's one error type, [`CmdError`]: its variant says what is at
//! fault (a flag, a file, a program the command runs, a stage of
//! `nerf-train` or `nerf-infer`) and its message, printed after `error: `,
//! names it and the cause and, where there is one, what to do. Every
//! subcommand returns [`CmdResult`]; the errors of the two crates convert
//! with `?` and keep their own words. [`OutOfRange`] is the error of the
//! [`num_in`](super::num_in) value parser, which clap prints after the flag.

use std::error::Error;
use std::fmt;
use std::path::{Path, PathBuf};

/// Everything that can stop a `nerf` command, by what is at fault.
#[derive(Debug, thiserror::Error)]
pub enum CmdError {
    /// A stage of `nerf-train` (a dataset, a configuration, a checkpoint,
    /// an export, a mesh, a plot), in its words.
    #[error(transparent)]
    Train(#[from] nerf_train::Error),
    /// A model `nerf-infer` cannot decode, encode or render, in its words.
    #[error(transparent)]
    Model(#[from] nerf_infer::Error),
    /// JSON that cannot be made (a report or a configuration serialised);
    /// a file that cannot be parsed is a [`CmdError::File`], naming it.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A file or folder that cannot be read, written, listed or created:
    /// its path, what could not be done and the system's reason.
    #[error("{}: {action}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What could not be done (`cannot write`).
        action: &'static str,
        /// What the system reported.
        #[source]
        source: std::io::Error,
    },
    /// A flag (or flags) whose value the command refuses: the flag, then
    /// the value and why (`--out runs/a: is a folder; …`).
    #[error("{flag} {reason}")]
    Flag {
        /// The flag, as typed (`--out`), or which flags
        /// (`--preset/--config`, `the loading flags`).
        flag: &'static str,
        /// What follows the flag in the message: its value and why it is
        /// refused.
        reason: String,
    },
    /// A command this binary cannot carry out as given: its command line
    /// lacks what it needs (a training budget, the views to render, a new
    /// run's configuration) or names a preset this build does not know,
    /// its flags together ask for too much (a frame, a GIF too large), or
    /// the build lacks it (the browser viewer); the whole message, with
    /// what to do.
    #[error("{0}")]
    Usage(String),
    /// A file or folder a user names (a model, a checkpoint, a dataset, an
    /// output folder) that the command cannot use as it is: its path and
    /// why.
    #[error("{}: {reason}", path.display())]
    File {
        /// The file or folder.
        path: PathBuf,
        /// What is wrong with it, and what to do.
        reason: String,
    },
    /// A program the command runs (a COLMAP stage, ffmpeg) that cannot be
    /// started, fails or leaves nothing: the stage and why.
    #[error("{stage}: {reason}")]
    Program {
        /// The stage, or what befell the program (`mapper`, `COLMAP
        /// registered no photos`).
        stage: String,
        /// What happened (the program's status and last lines).
        reason: String,
    },
    /// A search or a suite that ran to its end without what was asked (no
    /// candidate reaching the target or fitting `--max-bytes`, scenes of a
    /// bench without a result): what it found and where its table is, the
    /// whole message.
    #[error("{0}")]
    Unreached(String),
    /// Work stopped by an interrupt (Ctrl-C, SIGTERM): where it stopped and
    /// how to go on, the whole message.
    #[error("{0}")]
    Interrupted(String),
    /// An error in one named part of the command's work, or in a step it
    /// could not take (a bench's scene or task, a fit's candidate, a
    /// tradeoff's point, the reference model, the thread pool, the rename
    /// of a finished capture): the part, then the error.
    #[error("{part}: {source}")]
    In {
        /// The part or the step (`scene lego`, `reference`, `cannot start
        /// task 3 (…)`).
        part: String,
        /// The error in it.
        #[source]
        source: Box<dyn Error + Send + Sync>,
    },
    /// An error, then what it means for the command's outputs or what to do
    /// (what was kept, where a log went).
    #[error("{source}{note}")]
    Noted {
        /// The error.
        #[source]
        source: Box<CmdError>,
        /// What follows it in the message, from its separator on (`; it is
        /// kept in …`).
        note: String,
    },
}

impl CmdError {
    /// For `map_err` on an I/O result about `path`: the error as
    /// [`CmdError::Io`], naming the file and what could not be done.
    pub fn io<'a>(path: &'a Path, action: &'static str) -> impl FnOnce(std::io::Error) -> CmdError + 'a {
        move |source| CmdError::Io { path: path.to_path_buf(), action, source }
    }

    /// For `map_err` on a result about the file `path` whose error says
    /// what is wrong with it (a model `nerf-infer` refuses, a checkpoint
    /// `nerf-train` refuses): the error as [`CmdError::File`].
    pub fn file<E: fmt::Display>(path: &Path) -> impl FnOnce(E) -> CmdError + '_ {
        move |e| CmdError::File { path: path.to_path_buf(), reason: e.to_string() }
    }

    /// For `map_err` on a result of one part of the work: the error as
    /// [`CmdError::In`], naming `part`.
    pub fn within<E: Error + Send + Sync + 'static>(part: impl Into<String>) -> impl FnOnce(E) -> CmdError {
        let part = part.into();
        move |e| CmdError::In { part, source: Box::new(e) }
    }

    /// This error with `note` after it ([`CmdError::Noted`]); `note` starts
    /// with its separator (`; `, ` (`).
    pub fn noted(self, note: impl Into<String>) -> CmdError {
        CmdError::Noted { source: Box::new(self), note: note.into() }
    }
}

/// A dataset that cannot be loaded or written, in `nerf-train`'s words.
impl From<nerf_train::dataset::DataError> for CmdError {
    fn from(e: nerf_train::dataset::DataError) -> Self {
        CmdError::Train(e.into())
    }
}

/// A COLMAP model file that cannot be read, in `nerf-train`'s words.
impl From<nerf_train::error::ParseError> for CmdError {
    fn from(e: nerf_train::error::ParseError) -> Self {
        CmdError::Train(e.into())
    }
}

/// Result alias of the command: `()` for a subcommand's run.
pub type CmdResult<T = ()> = Result<T, CmdError>;

/// A value the [`num_in`](super::num_in) parser refuses (not a number,
/// NaN, or outside the range): the range, which clap prints after the flag
/// and the value.
#[derive(Clone, Debug, thiserror::Error)]
#[error("expected a number from {lo} to {hi}")]
pub struct OutOfRange {
    /// The least value accepted, as written.
    pub lo: String,
    /// The greatest value accepted, as written.
    pub hi: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_io_error_names_its_file_and_what_could_not_be_done() {
        let e = CmdError::io(Path::new("out/a.png"), "cannot write")(std::io::ErrorKind::PermissionDenied.into());
        let message = e.to_string();
        assert!(message.starts_with("out/a.png: cannot write: "), "{message}");
        let source = e.source().and_then(|s| s.downcast_ref::<std::io::Error>());
        assert_eq!(source.map(|s| s.kind()), Some(std::io::ErrorKind::PermissionDenied));
    }

    #[test]
    fn wrapped_errors_keep_the_words_around_them() {
        let flag = CmdError::Flag { flag: "--llffhold", reason: "must be at least 1".into() };
        assert_eq!(flag.to_string(), "--llffhold must be at least 1");
        let e = CmdError::within("scene lego")(flag).noted(" (nothing was written)");
        assert_eq!(e.to_string(), "scene lego: --llffhold must be at least 1 (nothing was written)");
        let model = CmdError::file(Path::new("m.nerf"))(nerf_infer::Error::BadMagic);
        assert_eq!(model.to_string(), format!("m.nerf: {}", nerf_infer::Error::BadMagic));
    }
}
