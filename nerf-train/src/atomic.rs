//! Atomic file output: every file the tools write appears whole or not at
//! all, whatever happens during the write (full disk, unwritable directory,
//! the process killed).

use std::io::{self, Cursor, Write};
use std::path::{Path, PathBuf};

/// The temporary name `path` is written under before the rename.
pub fn tmp_path(path: &Path) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(".tmp");
    PathBuf::from(s)
}

/// Writes `bytes` to `path` atomically: into `path.tmp` in the same
/// directory, flushed to disk, then renamed over `path`. On failure the
/// temporary file is removed and `path` is left as it was.
pub fn write(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = tmp_path(path);
    let res = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if res.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    res
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
