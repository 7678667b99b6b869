//! The output folders of `render`, `scene`, `eval --save` and `tradeoff`:
//! one policy. A command claims its folder before it writes anything: the
//! folder is created if missing and locked for the command's lifetime (a
//! second process writing it is refused), and it must be empty or hold
//! this same command's outputs of an earlier run, which its record
//! (`.nerf-outputs`: the command, then each entry it wrote) names; those
//! are removed first, so a shorter render leaves none of a longer one's
//! frames. A folder holding anything else (a user's files, another
//! command's results, a training run) is refused, and nothing in it is
//! touched. When the command ends well, the record lists what the folder
//! holds.

use super::{create_dir, lock_run_dir};
use std::path::{Path, PathBuf};

/// The record of a folder's outputs.
pub const RECORD: &str = ".nerf-outputs";

/// An output folder claimed by one command ([`OutDir::claim`]).
#[derive(Debug)]
pub struct OutDir {
    dir: PathBuf,
    command: &'static str,
    _lock: std::fs::File,
}

/// The command and entries a folder's record names, if it has one.
fn record(dir: &Path) -> Option<(String, Vec<String>)> {
    let text = std::fs::read_to_string(dir.join(RECORD)).ok()?;
    let mut lines = text.lines();
    let command = lines.next()?.strip_prefix("nerf ")?.to_string();
    Some((command, lines.map(str::to_string).collect()))
}

impl OutDir {
    /// Claims `dir` (the value of `flag`) for `command` (see the module doc).
    pub fn claim(dir: &Path, flag: &str, command: &'static str) -> Result<Self, String> {
        if dir.exists() && !dir.is_dir() {
            return Err(format!("{flag} {}: not a folder", dir.display()));
        }
        create_dir(dir)?;
        let lock = lock_run_dir(dir)?;
        let entries: Vec<String> = std::fs::read_dir(dir)
            .map_err(|e| format!("{flag} {}: cannot list: {e}", dir.display()))?
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n != RECORD)
            .collect();
        let (owner, ours) = record(dir).unwrap_or_default();
        if !entries.is_empty() && owner.is_empty() {
            return Err(format!(
                "{flag} {}: the folder holds files nerf {command} did not write ({}); give a new or empty folder",
                dir.display(),
                entries.iter().take(3).cloned().collect::<Vec<_>>().join(", ")
            ));
        }
        if !entries.is_empty() && owner != command {
            return Err(format!(
                "{flag} {}: holds the outputs of nerf {owner}; give another folder to nerf {command}",
                dir.display()
            ));
        }
        if let Some(other) = entries.iter().find(|e| !ours.contains(e)) {
            return Err(format!(
                "{flag} {}: holds {other}, which nerf {command} did not write; give a new or empty folder",
                dir.display()
            ));
        }
        // the earlier run's outputs: gone before the new ones are written
        for e in &ours {
            let p = dir.join(e);
            let gone = if p.is_dir() { std::fs::remove_dir_all(&p) } else { std::fs::remove_file(&p) };
            if let Err(err) = gone.or_else(|e| if p.exists() { Err(e) } else { Ok(()) }) {
                return Err(format!("{}: cannot remove an earlier output: {err}", p.display()));
            }
        }
        let this = Self { dir: dir.to_path_buf(), command, _lock: lock };
        // claimed from here: the record names the command while it writes
        this.write_record()?;
        Ok(this)
    }

    /// Records what the folder now holds: called when the command has
    /// written its outputs (and after a failure, so that a rerun may
    /// replace what it left).
    pub fn write_record(&self) -> Result<(), String> {
        let mut text = format!("nerf {}\n", self.command);
        let mut names: Vec<String> = std::fs::read_dir(&self.dir)
            .map_err(|e| format!("{}: cannot list: {e}", self.dir.display()))?
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n != RECORD)
            .collect();
        names.sort();
        for n in names {
            text.push_str(&n);
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
