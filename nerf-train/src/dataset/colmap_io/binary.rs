//! COLMAP's binary model files (`cameras.bin`, `images.bin`,
//! `points3D.bin`, little-endian), read with every count checked against the
//! bytes left, and written.

use super::*;

/// A little-endian cursor over a binary model file.
pub(super) struct Bin<'a> {
    path: &'a Path,
    b: &'a [u8],
    at: usize,
}

impl<'a> Bin<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], ParseError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.b.len());
        let end = end.ok_or_else(|| err(self.path, format!("truncated in {what} (at byte {})", self.at)))?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn arr<const N: usize>(&mut self, what: &str) -> Result<[u8; N], ParseError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N, what)?);
        Ok(a)
    }
    fn u64(&mut self, what: &str) -> Result<u64, ParseError> {
        Ok(u64::from_le_bytes(self.arr(what)?))
    }
    fn u32(&mut self, what: &str) -> Result<u32, ParseError> {
        Ok(u32::from_le_bytes(self.arr(what)?))
    }
    fn i32(&mut self, what: &str) -> Result<i32, ParseError> {
        Ok(i32::from_le_bytes(self.arr(what)?))
    }
    fn f64(&mut self, what: &str) -> Result<f64, ParseError> {
        Ok(f64::from_le_bytes(self.arr(what)?))
    }
    fn finite<const N: usize>(&mut self, what: &str) -> Result<[f64; N], ParseError> {
        let mut a = [0f64; N];
        for v in &mut a {
            *v = self.f64(what)?;
        }
        if a.iter().any(|v| !v.is_finite()) {
            return Err(err(self.path, format!("{what}: non-finite value")));
        }
        Ok(a)
    }
    /// A count of records of at least `min_size` bytes each, checked
    /// against the bytes left.
    fn count(&mut self, min_size: usize, what: &str) -> Result<usize, ParseError> {
        let n = self.u64(what)?;
        let left = (self.b.len() - self.at) as u64;
        if n.checked_mul(min_size as u64).is_none_or(|need| need > left) {
            return Err(err(self.path, format!("{what}: count {n} does not fit in the {left} bytes left")));
        }
        Ok(n as usize)
    }
    fn end(&self) -> Result<(), ParseError> {
        if self.at != self.b.len() {
            return Err(err(self.path, format!("{} unexpected bytes at the end", self.b.len() - self.at)));
        }
        Ok(())
    }
}

/// Reads `cameras.bin`.
pub fn read_cameras_bin(path: &Path) -> Result<Vec<ColmapCamera>, ParseError> {
    parse_cameras_bin(path, &read_file(path)?)
}

/// [`read_cameras_bin`] on the file's bytes (`path` names it in errors).
pub fn parse_cameras_bin(path: &Path, bytes: &[u8]) -> Result<Vec<ColmapCamera>, ParseError> {
    let mut r = Bin { path, b: bytes, at: 0 };
    let n = r.count(24, "camera count")?;
    let mut out = Vec::with_capacity(n);
    let mut seen = HashSet::new();
    for _ in 0..n {
        let id = r.u32("camera id")?;
        let model_id = r.i32("camera model")?;
        let model = CameraModel::from_id(model_id)
            .ok_or_else(|| err(path, format!("camera {id}: unknown camera model id {model_id}")))?;
        let (width, height) = (r.u64("width")?, r.u64("height")?);
        let mut params = Vec::with_capacity(model.num_params());
        for _ in 0..model.num_params() {
            params.push(r.f64("camera parameters")?);
        }
        let c = ColmapCamera { id, model, width, height, params };
        check_camera(path, &c, &mut seen)?;
        out.push(c);
    }
    r.end()?;
    Ok(out)
}

/// Reads `images.bin` (2-D points skipped).
pub fn read_images_bin(path: &Path) -> Result<Vec<ColmapImage>, ParseError> {
    parse_images_bin(path, &read_file(path)?)
}

/// [`read_images_bin`] on the file's bytes (`path` names it in errors).
pub fn parse_images_bin(path: &Path, bytes: &[u8]) -> Result<Vec<ColmapImage>, ParseError> {
    let mut r = Bin { path, b: bytes, at: 0 };
    let n = r.count(73, "image count")?;
    let mut out = Vec::with_capacity(n);
    let mut seen = HashSet::new();
    for _ in 0..n {
        let id = r.u32("image id")?;
        let what = format!("image {id}");
        let qvec = r.finite::<4>(&what)?;
        let tvec = r.finite::<3>(&what)?;
        let camera_id = r.u32("camera id")?;
        let rest = &r.b[r.at..];
        let len = rest.iter().position(|&c| c == 0).ok_or_else(|| err(path, format!("{what}: name not terminated")))?;
        let name =
            std::str::from_utf8(&rest[..len]).map_err(|_| err(path, format!("{what}: name is not UTF-8")))?.to_string();
        r.take(len + 1, "image name")?;
        let points = r.count(24, &format!("{what} ({name}): 2-D point count"))?;
        r.take(points * 24, "2-D points")?;
        let im = ColmapImage { id, qvec, tvec, camera_id, name };
        check_image(path, &im, &mut seen)?;
        out.push(im);
    }
    r.end()?;
    Ok(out)
}

/// Reads `points3D.bin`.
pub fn read_points_bin(path: &Path) -> Result<Vec<ColmapPoint>, ParseError> {
    parse_points_bin(path, &read_file(path)?)
}

/// [`read_points_bin`] on the file's bytes (`path` names it in errors).
pub fn parse_points_bin(path: &Path, bytes: &[u8]) -> Result<Vec<ColmapPoint>, ParseError> {
    let mut r = Bin { path, b: bytes, at: 0 };
    let n = r.count(51, "point count")?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let id = r.u64("point id")?;
        let what = format!("point {id}");
        let xyz = r.finite::<3>(&what)?;
        let rgb = r.arr::<3>("colour")?;
        let error = r.f64("error")?;
        let track_len = r.count(8, &format!("{what}: track length"))? as u64;
        r.take(track_len as usize * 8, "track")?;
        out.push(ColmapPoint { xyz, rgb, error, track_len });
    }
    r.end()?;
    Ok(out)
}

/// Writes `cameras.bin`, `images.bin` and `points3D.bin` into `model_dir`
/// (images without 2-D points; each point's track as `track_len` zero pairs).
pub fn write_model_bin(model_dir: &Path, r: &Reconstruction) -> std::io::Result<()> {
    let mut c = Vec::new();
    c.extend_from_slice(&(r.cameras.len() as u64).to_le_bytes());
    for cam in &r.cameras {
        c.extend_from_slice(&cam.id.to_le_bytes());
        c.extend_from_slice(&cam.model.id().to_le_bytes());
        c.extend_from_slice(&cam.width.to_le_bytes());
        c.extend_from_slice(&cam.height.to_le_bytes());
        cam.params.iter().for_each(|p| c.extend_from_slice(&p.to_le_bytes()));
    }
    let mut im = Vec::new();
    im.extend_from_slice(&(r.images.len() as u64).to_le_bytes());
    for i in &r.images {
        im.extend_from_slice(&i.id.to_le_bytes());
        i.qvec.iter().chain(&i.tvec).for_each(|v| im.extend_from_slice(&v.to_le_bytes()));
        im.extend_from_slice(&i.camera_id.to_le_bytes());
        im.extend_from_slice(i.name.as_bytes());
        im.push(0);
        im.extend_from_slice(&0u64.to_le_bytes());
    }
    let mut p = Vec::new();
    p.extend_from_slice(&(r.points.len() as u64).to_le_bytes());
    for (k, pt) in r.points.iter().enumerate() {
        p.extend_from_slice(&(k as u64 + 1).to_le_bytes());
        pt.xyz.iter().for_each(|v| p.extend_from_slice(&v.to_le_bytes()));
        p.extend_from_slice(&pt.rgb);
        p.extend_from_slice(&pt.error.to_le_bytes());
        p.extend_from_slice(&pt.track_len.to_le_bytes());
        p.extend(std::iter::repeat_n(0u8, pt.track_len as usize * 8));
    }
    crate::util::atomic::write(&model_dir.join("cameras.bin"), &c)?;
    crate::util::atomic::write(&model_dir.join("images.bin"), &im)?;
    crate::util::atomic::write(&model_dir.join("points3D.bin"), &p)
}
