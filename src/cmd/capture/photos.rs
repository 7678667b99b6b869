//! The photos of `nerf capture --photos`: which files of the folder are
//! readable JPEG or PNG photos and their sizes, what was skipped and why,
//! and their copy into the capture.

use crate::cmd::{CmdError, CmdResult};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What a folder of photos holds (only its own files: subfolders are
/// not read).
#[derive(Debug, Default)]
pub struct Survey {
    /// Readable photos with their stored width and height (pixels), in name order.
    pub photos: Vec<(PathBuf, (u32, u32))>,
    /// Files named as photos that cannot be read as one, with the reason.
    pub unreadable: Vec<(PathBuf, String)>,
    /// Other files by extension (lower case; "" for none), with a count.
    pub other: BTreeMap<String, usize>,
    /// Subfolders (not read).
    pub folders: usize,
}

/// Whether `p`'s extension names a JPEG or PNG file.
fn named_as_photo(p: &Path) -> bool {
    matches!(extension(p).as_str(), "jpg" | "jpeg" | "png")
}

fn extension(p: &Path) -> String {
    p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default()
}

/// Lists `dir` (`flag`'s value): each file named as a photo is opened to
/// read its size (the header only).
pub fn survey(dir: &Path, flag: &'static str) -> CmdResult<Survey> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| CmdError::Flag { flag, reason: format!("{}: cannot list: {e}", dir.display()) })?;
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok()).map(|e| e.path()).collect();
    paths.sort();
    let mut s = Survey::default();
    for p in paths {
        if p.is_dir() {
            s.folders += 1;
        } else if !named_as_photo(&p) {
            *s.other.entry(extension(&p)).or_default() += 1;
        } else {
            match image::image_dimensions(&p) {
                Ok(size) => s.photos.push((p, size)),
                // the decoder's message on one line
                Err(e) => s.unreadable.push((p, e.to_string().split_whitespace().collect::<Vec<_>>().join(" "))),
            }
        }
    }
    Ok(s)
}

impl Survey {
    /// What was left out, for the user (empty when nothing was): the
    /// unreadable photos named (the first few), the other files counted
    /// by extension, the subfolders counted.
    pub fn skipped(&self) -> String {
        let mut parts = Vec::new();
        if !self.unreadable.is_empty() {
            let named: Vec<String> = self
                .unreadable
                .iter()
                .take(3)
                .map(|(p, e)| format!("{} ({e})", p.file_name().unwrap_or_default().to_string_lossy()))
                .collect();
            let more = self.unreadable.len().saturating_sub(3);
            let more = if more > 0 { format!(" and {more} more") } else { String::new() };
            parts.push(format!("{} unreadable: {}{more}", self.unreadable.len(), named.join(", ")));
        }
        if !self.other.is_empty() {
            let kinds: Vec<String> = self
                .other
                .iter()
                .map(|(e, n)| if e.is_empty() { format!("{n} without extension") } else { format!("{n} .{e}") })
                .collect();
            parts.push(format!("{} not JPEG or PNG ({})", self.other.values().sum::<usize>(), kinds.join(", ")));
        }
        if self.folders > 0 {
            parts.push(format!("{} subfolder(s), not read", self.folders));
        }
        parts.join("; ")
    }

    /// Refuses photos of several sizes for one shared camera (COLMAP
    /// skips those whose size differs from the first one's), naming each
    /// size with a count and an example.
    pub fn one_size(&self, flag: &'static str, dir: &Path) -> CmdResult {
        let mut sizes: BTreeMap<(u32, u32), (usize, &Path)> = BTreeMap::new();
        for (p, size) in &self.photos {
            sizes.entry(*size).or_insert((0, p)).0 += 1;
        }
        if sizes.len() <= 1 {
            return Ok(());
        }
        let list: Vec<String> = sizes
            .iter()
            .map(|((w, h), (n, p))| {
                format!("{w}×{h}: {n}, e.g. {}", p.file_name().unwrap_or_default().to_string_lossy())
            })
            .collect();
        Err(CmdError::Flag {
            flag,
            reason: format!(
                "{}: photos of {} sizes ({}) cannot share one camera; give --camera-per-photo (a camera for each \
                 photo), or photos of one size",
                dir.display(),
                sizes.len(),
                list.join("; ")
            ),
        })
    }
}

/// Copies the surveyed photos into `to`.
pub fn copy(s: &Survey, to: &Path) -> CmdResult {
    for (p, _) in &s.photos {
        let name = p.file_name().expect("a listed file");
        std::fs::copy(p, to.join(name)).map_err(CmdError::io(p, "cannot copy"))?;
    }
    Ok(())
}
