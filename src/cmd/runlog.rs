//! `RUN_DIR/train.jsonl`: one JSON object per line. A write that fails (a
//! full disk) is rolled back so the file holds only whole lines; on
//! `--resume`, lines logged after the checkpoint's step are dropped, since
//! those steps are trained again.

use super::{CmdError, CmdResult};
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// An open training log.
pub struct RunLog {
    file: File,
    path: PathBuf,
    len: u64,
}

impl RunLog {
    /// Opens `path`: emptied for a fresh run (`resume_step` `None`), or
    /// cut back to the lines with `step ≤ resume_step` when resuming.
    pub fn open(path: &Path, resume_step: Option<u64>) -> CmdResult<Self> {
        let kept = match resume_step {
            None => String::new(),
            Some(step) => {
                let old = std::fs::read_to_string(path).unwrap_or_default();
                old.lines()
                    .filter(|l| {
                        let v: Option<serde_json::Value> = serde_json::from_str(l).ok();
                        v.and_then(|v| v["step"].as_u64()).is_some_and(|s| s <= step)
                    })
                    .flat_map(|l| [l, "\n"])
                    .collect()
            }
        };
        nerf_train::util::atomic::write(path, kept.as_bytes()).map_err(CmdError::io(path, "cannot write"))?;
        let file = OpenOptions::new().append(true).open(path).map_err(CmdError::io(path, "cannot write"))?;
        Ok(Self { file, path: path.to_path_buf(), len: kept.len() as u64 })
    }

    /// Appends one line; on failure the file is cut back to whole lines.
    pub fn append(&mut self, v: &serde_json::Value) -> CmdResult {
        let line = format!("{v}\n");
        if let Err(e) = self.file.write_all(line.as_bytes()).and_then(|_| self.file.flush()) {
            let _ = self.file.set_len(self.len);
            return Err(CmdError::io(&self.path, "cannot write")(e));
        }
        self.len += line.len() as u64;
        Ok(())
    }
}
