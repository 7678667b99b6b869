//! The output folders of `render`, `scene`, `eval --save`, `tradeoff`,
//! `web` and `fit`: one policy. A command claims its folder before it
//! writes anything: the folder is created if missing and locked for the
//! command's lifetime (a second process writing it is refused). The
//! folder's record (`.nerf-outputs`: the command, then each file it wrote,
//! relative to the folder) names what a nerf command wrote there.
//!
//! - A file the record does not name (a user's file, a training run, a
//!   file added among the outputs) is never removed: the folder is
//!   refused, naming it, with or without `--force`.
//! - The same command's outputs of an earlier run are removed first (and
//!   the folders they leave empty), so a shorter render leaves none of a
//!   longer one's frames; for a command whose outputs cost long to make
//!   ([`Earlier::NeedForce`]: `fit`) only with `--force`.
//! - Another command's recorded outputs are removed only with `--force`.
//!
//! So `--force` means the same for every command that takes it: replace
//! what nerf wrote in the folder, never anything else (`train --force`
//! replaces a run's checkpoint, model and log the same way). When the
//! command ends, well or not, the record lists the files the folder then
//! holds.

use super::{create_dir, lock_run_dir, CmdError, CmdResult};
use std::collections::BTreeSet;
use std::path::{Component, Path, PathBuf};

/// The record of a folder's outputs.
pub const RECORD: &str = ".nerf-outputs";

/// How a command treats its own outputs of an earlier run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Earlier {
    /// Removed first: they are quick to make again.
    Replace,
    /// Removed only with `--force`, refused without: they took long to make.
    NeedForce,
}

/// An output folder claimed by one command ([`OutDir::claim`]).
#[derive(Debug)]
pub struct OutDir {
    dir: PathBuf,
    command: &'static str,
    _lock: std::fs::File,
}

/// Every file under `dir` (symbolic links as files, not followed), as
/// paths relative to it, the record left out.
fn files(dir: &Path) -> CmdResult<BTreeSet<PathBuf>> {
    let mut out = BTreeSet::new();
    let mut todo = vec![PathBuf::new()];
    while let Some(rel) = todo.pop() {
        let here = dir.join(&rel);
        let rd = std::fs::read_dir(&here).map_err(CmdError::io(&here, "cannot list"))?;
        for e in rd.filter_map(|e| e.ok()) {
            let p = rel.join(e.file_name());
            match e.file_type() {
                Ok(t) if t.is_dir() => todo.push(p),
                _ if p.as_os_str() == RECORD => {}
                _ => {
                    out.insert(p);
                }
            }
        }
    }
    Ok(out)
}

/// The command and files a folder's record names, if it has one; names
/// that leave the folder (absolute, `..`) are not the record's.
fn record(dir: &Path) -> Option<(String, BTreeSet<PathBuf>)> {
    let text = std::fs::read_to_string(dir.join(RECORD)).ok()?;
    let mut lines = text.lines();
    let command = lines.next()?.strip_prefix("nerf ")?.to_string();
    let inside = |p: &Path| !p.as_os_str().is_empty() && p.components().all(|c| matches!(c, Component::Normal(_)));
    Some((command, lines.map(PathBuf::from).filter(|p| inside(p)).collect()))
}

impl OutDir {
    /// Claims `dir` (the value of `flag`) for `command`, which treats its
    /// earlier outputs as `earlier` says; `force` is the command's
    /// `--force` (see the module doc).
    pub fn claim(
        dir: &Path,
        flag: &'static str,
        command: &'static str,
        earlier: Earlier,
        force: bool,
    ) -> CmdResult<Self> {
        let refused = |reason: String| Err(CmdError::Flag { flag, reason });
        if dir.exists() && !dir.is_dir() {
            return refused(format!("{}: not a folder", dir.display()));
        }
        create_dir(dir)?;
        let lock = lock_run_dir(dir)?;
        let present = files(dir)?;
        let (owner, ours) = record(dir).unwrap_or_default();
        if let Some(other) = present.iter().find(|p| !ours.contains(*p)) {
            let run = ["model.nerf", "checkpoint.bin", "train.jsonl"].iter().any(|f| other.as_os_str() == *f);
            return refused(format!(
                "{}: holds {}{}, which nerf {command} did not write (no nerf command recorded it, so even --force \
                 leaves it); give a new or empty folder",
                dir.display(),
                other.display(),
                if run { ", a training run's" } else { "" }
            ));
        }
        let needs_force = owner != command || earlier == Earlier::NeedForce;
        if let (Some(first), true, false) = (present.first(), needs_force, force) {
            let whose =
                if owner == command { format!("an earlier run of nerf {command}") } else { format!("nerf {owner}") };
            return refused(format!(
                "{}: holds the outputs of {whose} ({} and {} more); give a new or empty folder, or --force to \
                 replace them",
                dir.display(),
                first.display(),
                present.len() - 1
            ));
        }
        // the earlier run's outputs, all of them recorded: gone before the new ones are written
        for p in &present {
            let full = dir.join(p);
            std::fs::remove_file(&full).map_err(CmdError::io(&full, "cannot remove an earlier output"))?;
            // the folders that held it, if now empty (a folder holding anything stays)
            for a in p.ancestors().skip(1).filter(|a| !a.as_os_str().is_empty()) {
                if std::fs::remove_dir(dir.join(a)).is_err() {
                    break;
                }
            }
        }
        let this = Self { dir: dir.to_path_buf(), command, _lock: lock };
        // claimed from here: the record names the command while it writes
        this.write_record()?;
        Ok(this)
    }

    /// Records the files the folder now holds as this command's.
    pub fn write_record(&self) -> CmdResult {
        let mut text = format!("nerf {}\n", self.command);
        for p in files(&self.dir)? {
            text.push_str(&p.to_string_lossy());
            text.push('\n');
        }
        super::write_atomic(&self.dir.join(RECORD), text.as_bytes())
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        // whatever was written, even by a failed run, is this command's to replace
        let _ = self.write_record();
    }
}
