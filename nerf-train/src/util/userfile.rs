//! Reading a file a user named: a regular file (not a folder, FIFO,
//! device or socket, which could block or never end) of at most a stated
//! size, read whole; the error names the file and the cause.

use crate::error::{Error, FileError, ReadError};
use std::io::Read;
use std::path::Path;

/// Most bytes of a JSON file a user names (configurations, camera paths,
/// `transforms.json`).
pub const MAX_JSON: u64 = 64 << 20;

/// Reads `path` whole if it is a regular file (symbolic links followed) of
/// at most `max` bytes; else an error naming the file, what it was
/// expected to be (`what`, e.g. "camera path") and why it is refused.
pub fn read_user_file(path: &Path, max: u64, what: &str) -> Result<Vec<u8>, Error> {
    read_checked(path, max).map_err(|reason| unreadable(path, what, reason))
}

/// The error of a file `path` that cannot be read whole as a `what`.
fn unreadable(path: &Path, what: &str, reason: ReadError) -> Error {
    Error::File(FileError::Unreadable { path: path.to_path_buf(), what: what.to_string(), reason })
}

/// [`read_user_file`] whose error is the cause alone, a [`ReadError`]
/// (for errors that name the file themselves).
pub fn read_checked(path: &Path, max: u64) -> Result<Vec<u8>, ReadError> {
    let cannot = |action| move |source| ReadError::Io { action, source };
    let meta = std::fs::metadata(path).map_err(cannot("cannot read"))?;
    if meta.is_dir() {
        return Err(ReadError::Folder);
    }
    if !meta.is_file() {
        return Err(ReadError::NotRegular);
    }
    if meta.len() > max {
        return Err(ReadError::TooLarge { size: meta.len(), max });
    }
    let mut opts = std::fs::OpenOptions::new();
    opts.read(true);
    #[cfg(unix)]
    {
        // a file swapped for a FIFO after the check must not block the open
        use std::os::unix::fs::OpenOptionsExt;
        opts.custom_flags(libc::O_NONBLOCK);
    }
    let f = opts.open(path).map_err(cannot("cannot open"))?;
    if !f.metadata().map_err(cannot("cannot read"))?.is_file() {
        return Err(ReadError::Swapped);
    }
    let mut buf = Vec::with_capacity(meta.len() as usize);
    f.take(max + 1).read_to_end(&mut buf).map_err(cannot("cannot read"))?;
    if buf.len() as u64 > max {
        return Err(ReadError::Grown { max });
    }
    Ok(buf)
}

/// [`read_user_file`] as UTF-8 text (a leading byte-order mark dropped).
pub fn read_user_text(path: &Path, max: u64, what: &str) -> Result<String, Error> {
    let bytes = read_user_file(path, max, what)?;
    let text = String::from_utf8(bytes).map_err(|e| unreadable(path, what, ReadError::NotUtf8(e.utf8_error())))?;
    Ok(text.strip_prefix('\u{feff}').map(str::to_string).unwrap_or(text))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folders_fifos_devices_and_large_files_are_refused_by_name() {
        let d = std::env::temp_dir().join(format!("nerf-userfile-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let f = d.join("a.json");
        std::fs::write(&f, "\u{feff}{}").unwrap();
        assert_eq!(read_user_text(&f, 100, "camera path").unwrap(), "{}");
        let e = read_user_file(&f, 2, "camera path").unwrap_err().to_string();
        assert!(e.contains("a.json") && e.contains("camera path") && e.contains("more than the 2"), "{e}");
        assert!(read_user_file(&d, 100, "model").unwrap_err().to_string().contains("folder"));
        #[cfg(unix)]
        {
            let fifo = d.join("fifo");
            let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
            // SAFETY: mkfifo on a NUL-terminated path this test owns.
            assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
            let e = read_user_file(&fifo, 100, "model").unwrap_err().to_string();
            assert!(e.contains("FIFO"), "{e}");
            let e = read_user_file(Path::new("/dev/zero"), 100, "camera path").unwrap_err().to_string();
            assert!(e.contains("not a regular file"), "{e}");
        }
        std::fs::remove_dir_all(&d).unwrap();
    }
}
