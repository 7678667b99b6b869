//! Atomic file output: every file the tools write appears whole or not at
//! all, whatever happens during the write (full disk, unwritable directory,
//! the process killed).
//!
//! The bytes go to a temporary file with a unique name in the target's
//! directory (the `tempfile` crate: `.tmpXXXXXX`, created exclusively, so
//! no file of the user's is ever taken over or deleted), are flushed to
//! disk, then renamed over the target, and the directory is flushed so the
//! rename survives a power cut. Only a regular file (or nothing) is
//! replaced: a device node, FIFO, socket or directory at the target is
//! refused, and so is a symbolic link (renaming over it would replace the
//! link, not the file it points to, which is never what was meant).
//!
//! The temporary files being written are listed ([`remove_in_flight`]), so
//! that a program stopped by a signal can remove them before it exits.

use std::io::{self, Cursor, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The temporary files this process is writing.
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A temporary file listed in [`IN_FLIGHT`] while it lives.
struct Listed(PathBuf);

impl Drop for Listed {
    fn drop(&mut self) {
        if let Ok(mut l) = IN_FLIGHT.lock() {
            l.retain(|p| *p != self.0);
        }
    }
}

/// Removes the temporary files this process is writing (for a signal
/// handler about to exit: a write it cuts short leaves nothing). Does
/// nothing if the list is held at that moment.
pub fn remove_in_flight() {
    if let Ok(l) = IN_FLIGHT.try_lock() {
        for p in l.iter() {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// Fails unless `path` is absent or a regular file (not a symlink).
pub fn check_replaceable(path: &Path) -> io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
        Ok(m) if m.file_type().is_file() => Ok(()),
        Ok(m) => {
            let what = if m.file_type().is_symlink() {
                "a symbolic link"
            } else if m.is_dir() {
                "a directory"
            } else {
                "not a regular file (a device, FIFO or socket)"
            };
            Err(io::Error::other(format!("is {what}; refusing to replace it")))
        }
    }
}

/// Writes `bytes` to `path` atomically (see the module doc). On failure
/// the temporary file is removed and `path` is left as it was.
pub fn write(path: &Path, bytes: &[u8]) -> io::Result<()> {
    check_replaceable(path)?;
    let (tmp, _listed) = written_beside(path, bytes)?;
    tmp.persist(path).map_err(|e| e.error)?;
    // the rename is durable once the directory is flushed (not possible on every platform: best effort)
    if let Ok(d) = std::fs::File::open(folder_of(path)) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// The folder `path` is in (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// `bytes` in a new temporary file beside `path` (`.tmpXXXXXX`, created
/// exclusively, mode 0666 less the umask), flushed to disk; removed when
/// dropped unless persisted, and listed for [`remove_in_flight`] while the
/// second value lives.
fn written_beside(path: &Path, bytes: &[u8]) -> io::Result<(tempfile::NamedTempFile, Listed)> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(".tmp");
    // as File::create: mode 0666 less the umask (tempfile's own default, 0600, would hide outputs from other users)
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let mut tmp = builder.tempfile_in(folder_of(path))?;
    let listed = Listed(tmp.path().to_path_buf());
    if let Ok(mut l) = IN_FLIGHT.lock() {
        l.push(listed.0.clone());
    }
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    Ok((tmp, listed))
}

/// Writes `bytes` to `path` atomically if nothing is there yet: the file
/// appears whole, and of several processes creating it at once (on one
/// machine or over a network file system) exactly one succeeds. Returns
/// `Ok(false)`, writing nothing, when `path` already exists.
pub fn write_new(path: &Path, bytes: &[u8]) -> io::Result<bool> {
    let (tmp, _listed) = written_beside(path, bytes)?;
    match tmp.persist_noclobber(path) {
        Ok(_) => Ok(true),
        Err(e) if e.error.kind() == io::ErrorKind::AlreadyExists => Ok(false),
        Err(e) => Err(e.error),
    }
}

/// Encodes `img` as PNG in memory and writes it atomically to `path`.
pub fn write_png<P, C>(path: &Path, img: &image::ImageBuffer<P, C>) -> io::Result<()>
where
    P: image::Pixel + image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
    C: std::ops::Deref<Target = [P::Subpixel]>,
{
    let mut buf = Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png).map_err(io::Error::other)?;
    write(path, buf.get_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporary_files_are_listed_while_they_live_and_a_signal_handler_can_remove_them() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("model.nerf");
        let (tmp, listed) = written_beside(&target, b"bytes").unwrap();
        let path = tmp.path().to_path_buf();
        assert!(IN_FLIGHT.lock().unwrap().contains(&path));
        remove_in_flight();
        assert!(!path.exists(), "removed");
        drop((tmp, listed));
        assert!(!IN_FLIGHT.lock().unwrap().contains(&path), "unlisted when dropped");
        write(&target, b"whole").unwrap();
        assert!(IN_FLIGHT.lock().unwrap().is_empty(), "a finished write leaves nothing listed");
        assert_eq!(std::fs::read(&target).unwrap(), b"whole");
    }
}
