//! COLMAP sparse models on disk: `cameras`, `images` and `points3D` in
//! COLMAP's binary (`.bin`, little-endian) and text (`.txt`) formats, read
//! and written (the layouts of COLMAP's `read_write_model.py`).
//!
//! Every count in a file is checked against the bytes left before anything
//! is allocated from it, every value must be finite, and every failure is a
//! [`ParseError`] naming the file and the record: a damaged or hostile file
//! gives an error, never a panic or a huge allocation.

use std::collections::HashSet;
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

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

fn err(path: &Path, msg: impl Into<String>) -> ParseError {
    ParseError { path: path.to_path_buf(), msg: msg.into() }
}

/// COLMAP's camera models (id, name and parameter count as COLMAP defines them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraModel {
    /// 0: `f, cx, cy`.
    SimplePinhole,
    /// 1: `fx, fy, cx, cy`.
    Pinhole,
    /// 2: `f, cx, cy, k`.
    SimpleRadial,
    /// 3: `f, cx, cy, k1, k2`.
    Radial,
    /// 4: `fx, fy, cx, cy, k1, k2, p1, p2`.
    Opencv,
    /// 5: `fx, fy, cx, cy, k1, k2, k3, k4`.
    OpencvFisheye,
    /// 6: `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6`.
    FullOpencv,
    /// 7: `fx, fy, cx, cy, omega`.
    Fov,
    /// 8: `f, cx, cy, k`.
    SimpleRadialFisheye,
    /// 9: `f, cx, cy, k1, k2`.
    RadialFisheye,
    /// 10: `fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, sx1, sy1`.
    ThinPrismFisheye,
    /// 11: 16 parameters.
    RadTanThinPrismFisheye,
}

const MODELS: [(CameraModel, &str, usize); 12] = [
    (CameraModel::SimplePinhole, "SIMPLE_PINHOLE", 3),
    (CameraModel::Pinhole, "PINHOLE", 4),
    (CameraModel::SimpleRadial, "SIMPLE_RADIAL", 4),
    (CameraModel::Radial, "RADIAL", 5),
    (CameraModel::Opencv, "OPENCV", 8),
    (CameraModel::OpencvFisheye, "OPENCV_FISHEYE", 8),
    (CameraModel::FullOpencv, "FULL_OPENCV", 12),
    (CameraModel::Fov, "FOV", 5),
    (CameraModel::SimpleRadialFisheye, "SIMPLE_RADIAL_FISHEYE", 4),
    (CameraModel::RadialFisheye, "RADIAL_FISHEYE", 5),
    (CameraModel::ThinPrismFisheye, "THIN_PRISM_FISHEYE", 12),
    (CameraModel::RadTanThinPrismFisheye, "RAD_TAN_THIN_PRISM_FISHEYE", 16),
];

impl CameraModel {
    /// The model with COLMAP's numeric id.
    pub fn from_id(id: i32) -> Option<Self> {
        usize::try_from(id).ok().and_then(|i| MODELS.get(i)).map(|m| m.0)
    }

    /// COLMAP's numeric id.
    pub fn id(self) -> i32 {
        MODELS.iter().position(|m| m.0 == self).map_or(-1, |i| i as i32)
    }

    /// The model with COLMAP's name (`PINHOLE`, …).
    pub fn from_name(name: &str) -> Option<Self> {
        MODELS.iter().find(|m| m.1 == name).map(|m| m.0)
    }

    /// COLMAP's name.
    pub fn name(self) -> &'static str {
        MODELS.iter().find(|m| m.0 == self).map_or("?", |m| m.1)
    }

    /// Number of parameters.
    pub fn num_params(self) -> usize {
        MODELS.iter().find(|m| m.0 == self).map_or(0, |m| m.2)
    }
}

/// One camera: model, image size in pixels and parameters (pixels, and
/// distortion coefficients on normalised coordinates).
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapCamera {
    /// Camera id.
    pub id: u32,
    /// Camera model.
    pub model: CameraModel,
    /// Image width, pixels.
    pub width: u64,
    /// Image height, pixels.
    pub height: u64,
    /// The model's parameters, `model.num_params()` of them.
    pub params: Vec<f64>,
}

/// One registered image: its world-to-camera pose (OpenCV axes), camera
/// and file name under `images/`. Its 2-D points are read and skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapImage {
    /// Image id.
    pub id: u32,
    /// World-to-camera rotation as a quaternion `(w, x, y, z)`.
    pub qvec: [f64; 4],
    /// World-to-camera translation, world units.
    pub tvec: [f64; 3],
    /// The camera it was taken with.
    pub camera_id: u32,
    /// File name relative to `images/`.
    pub name: String,
}

/// One sparse point: position (world units), colour, reprojection error
/// (pixels) and the number of images that see it.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapPoint {
    /// Position, world units.
    pub xyz: [f64; 3],
    /// Colour, 8-bit RGB.
    pub rgb: [u8; 3],
    /// Mean reprojection error, pixels.
    pub error: f64,
    /// Number of observations.
    pub track_len: u64,
}

/// A sparse model.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Reconstruction {
    /// Cameras.
    pub cameras: Vec<ColmapCamera>,
    /// Registered images.
    pub images: Vec<ColmapImage>,
    /// Sparse points.
    pub points: Vec<ColmapPoint>,
}

/// Reads the model in `model_dir`, each part from `.bin` if present, else
/// `.txt`. Cameras and images are required; points are optional.
pub fn read_model(model_dir: &Path) -> Result<Reconstruction, ParseError> {
    let pick = |stem: &str| {
        let bin = model_dir.join(format!("{stem}.bin"));
        let txt = model_dir.join(format!("{stem}.txt"));
        if bin.is_file() {
            Some((bin, true))
        } else if txt.is_file() {
            Some((txt, false))
        } else {
            None
        }
    };
    let missing = |stem: &str| err(&model_dir.join(format!("{stem}.bin")), format!("no {stem}.bin or {stem}.txt"));
    let (cp, cb) = pick("cameras").ok_or_else(|| missing("cameras"))?;
    let cameras = if cb { read_cameras_bin(&cp)? } else { read_cameras_txt(&cp)? };
    let (ip, ib) = pick("images").ok_or_else(|| missing("images"))?;
    let images = if ib { read_images_bin(&ip)? } else { read_images_txt(&ip)? };
    // one photo with two poses contradicts itself: which one is right cannot be told
    let mut names: std::collections::HashMap<&str, u32> = Default::default();
    for im in &images {
        if let Some(first) = names.insert(im.name.as_str(), im.id) {
            return Err(err(
                &ip,
                format!("images {first} and {} both name {}: one photo with two poses; remove one", im.id, im.name),
            ));
        }
    }
    let ids: HashSet<u32> = cameras.iter().map(|c| c.id).collect();
    if let Some(im) = images.iter().find(|im| !ids.contains(&im.camera_id)) {
        return Err(err(
            &ip,
            format!("image {} ({}): camera {} is not in the cameras file", im.id, im.name, im.camera_id),
        ));
    }
    let points = match pick("points3D") {
        Some((p, true)) => read_points_bin(&p)?,
        Some((p, false)) => read_points_txt(&p)?,
        None => Vec::new(),
    };
    Ok(Reconstruction { cameras, images, points })
}

/// Largest model file read (2 GiB).
const MAX_FILE: u64 = 2 << 30;

fn read_file(path: &Path) -> Result<Vec<u8>, ParseError> {
    crate::userfile::read_checked(path, MAX_FILE).map_err(|e| err(path, e))
}

/// A little-endian cursor over a binary model file.
struct Bin<'a> {
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

fn check_camera(path: &Path, c: &ColmapCamera, seen: &mut HashSet<u32>) -> Result<(), ParseError> {
    let what = format!("camera {}", c.id);
    if !seen.insert(c.id) {
        return Err(err(path, format!("{what}: id appears twice")));
    }
    if c.width == 0 || c.height == 0 || c.width > 1 << 20 || c.height > 1 << 20 {
        return Err(err(path, format!("{what}: image size {}x{} out of range", c.width, c.height)));
    }
    if c.params.iter().any(|p| !p.is_finite()) {
        return Err(err(path, format!("{what}: non-finite parameter")));
    }
    Ok(())
}

fn check_image(path: &Path, im: &ColmapImage, seen: &mut HashSet<u32>) -> Result<(), ParseError> {
    if !seen.insert(im.id) {
        return Err(err(path, format!("image {} ({}): id appears twice", im.id, im.name)));
    }
    if im.name.is_empty() {
        return Err(err(path, format!("image {}: empty name", im.id)));
    }
    Ok(())
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

/// The non-comment, non-blank lines of a text model with their line numbers.
fn text_lines(path: &Path, bytes: &[u8]) -> Result<Vec<(usize, String)>, ParseError> {
    let text = std::str::from_utf8(bytes).map_err(|_| err(path, "not UTF-8 text"))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    Ok(text.lines().enumerate().map(|(i, l)| (i + 1, l.to_string())).filter(|(_, l)| !l.starts_with('#')).collect())
}

fn field<T: std::str::FromStr>(path: &Path, line: usize, tok: Option<&str>, what: &str) -> Result<T, ParseError> {
    let tok = tok.ok_or_else(|| err(path, format!("line {line}: missing {what}")))?;
    tok.parse().map_err(|_| err(path, format!("line {line}: {what} '{tok}' is not a valid number")))
}

fn finite_field(path: &Path, line: usize, tok: Option<&str>, what: &str) -> Result<f64, ParseError> {
    let v: f64 = field(path, line, tok, what)?;
    if !v.is_finite() {
        return Err(err(path, format!("line {line}: {what} is not finite")));
    }
    Ok(v)
}

/// Reads `cameras.txt`.
pub fn read_cameras_txt(path: &Path) -> Result<Vec<ColmapCamera>, ParseError> {
    parse_cameras_txt(path, &read_file(path)?)
}

/// [`read_cameras_txt`] on the file's bytes (`path` names it in errors).
pub fn parse_cameras_txt(path: &Path, bytes: &[u8]) -> Result<Vec<ColmapCamera>, ParseError> {
    let mut out = Vec::new();
    let mut seen = HashSet::new();
    for (ln, l) in text_lines(path, bytes)? {
        let mut t = l.split_whitespace();
        let Some(first) = t.next() else { continue };
        let id: u32 = field(path, ln, Some(first), "camera id")?;
        let name = t.next().ok_or_else(|| err(path, format!("line {ln}: missing camera model")))?;
        let model = CameraModel::from_name(name)
            .ok_or_else(|| err(path, format!("line {ln}: camera {id}: unknown camera model {name}")))?;
        let width = field(path, ln, t.next(), "width")?;
        let height = field(path, ln, t.next(), "height")?;
        let params: Vec<f64> = t.map(|p| field(path, ln, Some(p), "parameter")).collect::<Result<_, _>>()?;
        if params.len() != model.num_params() {
            return Err(err(
                path,
                format!("line {ln}: camera {id}: {name} has {} parameters, found {}", model.num_params(), params.len()),
            ));
        }
        let c = ColmapCamera { id, model, width, height, params };
        check_camera(path, &c, &mut seen)?;
        out.push(c);
    }
    Ok(out)
}

/// Reads `images.txt`: per image a pose line, then a line of 2-D points
/// (possibly empty, or missing after the last image).
pub fn read_images_txt(path: &Path) -> Result<Vec<ColmapImage>, ParseError> {
    parse_images_txt(path, &read_file(path)?)
}

/// [`read_images_txt`] on the file's bytes (`path` names it in errors).
pub fn parse_images_txt(path: &Path, bytes: &[u8]) -> Result<Vec<ColmapImage>, ParseError> {
    let text = std::str::from_utf8(bytes).map_err(|_| err(path, "not UTF-8 text"))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.starts_with('#'));
    let mut out = Vec::new();
    let mut seen = HashSet::new();
    while let Some((i, l)) = lines.next() {
        let ln = i + 1;
        if l.trim().is_empty() {
            continue;
        }
        let mut t = l.split_whitespace();
        let id: u32 = field(path, ln, t.next(), "image id")?;
        let mut q = [0f64; 4];
        for v in &mut q {
            *v = finite_field(path, ln, t.next(), "quaternion")?;
        }
        let mut tv = [0f64; 3];
        for v in &mut tv {
            *v = finite_field(path, ln, t.next(), "translation")?;
        }
        let camera_id: u32 = field(path, ln, t.next(), "camera id")?;
        let name = t.collect::<Vec<_>>().join(" ");
        let im = ColmapImage { id, qvec: q, tvec: tv, camera_id, name };
        check_image(path, &im, &mut seen)?;
        out.push(im);
        // the 2-D points line: triples of numbers, skipped
        if let Some((j, p)) = lines.next() {
            if p.split_whitespace().count() % 3 != 0 {
                return Err(err(path, format!("line {}: 2-D points are not (x, y, point id) triples", j + 1)));
            }
        }
    }
    Ok(out)
}

/// Reads `points3D.txt`.
pub fn read_points_txt(path: &Path) -> Result<Vec<ColmapPoint>, ParseError> {
    parse_points_txt(path, &read_file(path)?)
}

/// [`read_points_txt`] on the file's bytes (`path` names it in errors).
pub fn parse_points_txt(path: &Path, bytes: &[u8]) -> Result<Vec<ColmapPoint>, ParseError> {
    let mut out = Vec::new();
    for (ln, l) in text_lines(path, bytes)? {
        let mut t = l.split_whitespace();
        let Some(first) = t.next() else { continue };
        let _id: u64 = field(path, ln, Some(first), "point id")?;
        let mut xyz = [0f64; 3];
        for v in &mut xyz {
            *v = finite_field(path, ln, t.next(), "position")?;
        }
        let mut rgb = [0u8; 3];
        for v in &mut rgb {
            *v = field(path, ln, t.next(), "colour")?;
        }
        let error = field(path, ln, t.next(), "error")?;
        let rest = t.count();
        if rest % 2 != 0 {
            return Err(err(path, format!("line {ln}: track is not (image id, point index) pairs")));
        }
        out.push(ColmapPoint { xyz, rgb, error, track_len: (rest / 2) as u64 });
    }
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
    crate::atomic::write(&model_dir.join("cameras.bin"), &c)?;
    crate::atomic::write(&model_dir.join("images.bin"), &im)?;
    crate::atomic::write(&model_dir.join("points3D.bin"), &p)
}

/// Writes `cameras.txt`, `images.txt` and `points3D.txt` into `model_dir`
/// with COLMAP's header comments; numbers in Rust's shortest round-trip
/// form, so a model reads back exactly.
pub fn write_model_txt(model_dir: &Path, r: &Reconstruction) -> std::io::Result<()> {
    let mut c = Vec::new();
    writeln!(c, "# Camera list with one line of data per camera:")?;
    writeln!(c, "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]")?;
    writeln!(c, "# Number of cameras: {}", r.cameras.len())?;
    for cam in &r.cameras {
        let params: Vec<String> = cam.params.iter().map(|p| p.to_string()).collect();
        writeln!(c, "{} {} {} {} {}", cam.id, cam.model.name(), cam.width, cam.height, params.join(" "))?;
    }
    let mut im = Vec::new();
    writeln!(im, "# Image list with two lines of data per image:")?;
    writeln!(im, "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME")?;
    writeln!(im, "#   POINTS2D[] as (X, Y, POINT3D_ID)")?;
    writeln!(im, "# Number of images: {}", r.images.len())?;
    for i in &r.images {
        let [qw, qx, qy, qz] = i.qvec;
        let [tx, ty, tz] = i.tvec;
        writeln!(im, "{} {qw} {qx} {qy} {qz} {tx} {ty} {tz} {} {}", i.id, i.camera_id, i.name)?;
        writeln!(im)?;
    }
    let mut p = Vec::new();
    writeln!(p, "# 3D point list with one line of data per point:")?;
    writeln!(p, "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)")?;
    writeln!(p, "# Number of points: {}", r.points.len())?;
    for (k, pt) in r.points.iter().enumerate() {
        let [x, y, z] = pt.xyz;
        let [cr, cg, cb] = pt.rgb;
        write!(p, "{} {x} {y} {z} {cr} {cg} {cb} {}", k + 1, pt.error)?;
        for _ in 0..pt.track_len {
            write!(p, " 0 0")?;
        }
        writeln!(p)?;
    }
    crate::atomic::write(&model_dir.join("cameras.txt"), &c)?;
    crate::atomic::write(&model_dir.join("images.txt"), &im)?;
    crate::atomic::write(&model_dir.join("points3D.txt"), &p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh directory, removed with the guard.
    fn tmp(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("nerf-colmap-io-{name}-")).tempdir().unwrap()
    }

    fn sample() -> Reconstruction {
        Reconstruction {
            cameras: vec![
                ColmapCamera {
                    id: 1,
                    model: CameraModel::SimplePinhole,
                    width: 640,
                    height: 480,
                    params: vec![500.5, 320.0, 240.25],
                },
                ColmapCamera {
                    id: 7,
                    model: CameraModel::Opencv,
                    width: 800,
                    height: 600,
                    params: vec![600.0, 601.0, 400.0, 300.0, 0.1, -0.02, 0.001, -0.0005],
                },
            ],
            images: vec![
                ColmapImage {
                    id: 3,
                    qvec: [0.9, 0.1, -0.3, 0.2],
                    tvec: [1.0 / 3.0, -2.0, 5.5],
                    camera_id: 1,
                    name: "a b.jpg".into(),
                },
                ColmapImage {
                    id: 4,
                    qvec: [1.0, 0.0, 0.0, 0.0],
                    tvec: [0.0, 0.0, 1e-17],
                    camera_id: 7,
                    name: "sub/c.png".into(),
                },
            ],
            points: vec![
                ColmapPoint { xyz: [0.1, 0.2, 0.3], rgb: [1, 2, 255], error: 0.75, track_len: 3 },
                ColmapPoint { xyz: [-1e3, 2.5, std::f64::consts::PI], rgb: [0, 0, 0], error: 0.0, track_len: 0 },
            ],
        }
    }

    #[test]
    fn binary_and_text_round_trip_to_the_same_model() {
        let d_dir = tmp("round-trip");
        let d = d_dir.path();
        let (b, t) = (d.join("bin"), d.join("txt"));
        std::fs::create_dir_all(&b).unwrap();
        std::fs::create_dir_all(&t).unwrap();
        write_model_bin(&b, &sample()).unwrap();
        write_model_txt(&t, &sample()).unwrap();
        assert_eq!(read_model(&b).unwrap(), sample());
        assert_eq!(read_model(&t).unwrap(), sample());
    }

    #[test]
    fn colmaps_text_layout_reads() {
        let d_dir = tmp("text");
        let d = d_dir.path();
        std::fs::write(d.join("cameras.txt"), "# Camera list\n# Number of cameras: 1\n1 PINHOLE 100 80 90 91 50 40\n")
            .unwrap();
        std::fs::write(
            d.join("images.txt"),
            "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n\
             1 1 0 0 0 0 0 0 1 x.jpg\n10.5 20.5 -1 11 12 3\n2 1 0 0 0 1 2 3 1 y.jpg\n\n3 1 0 0 0 0 0 1 1 z.jpg",
        )
        .unwrap();
        let r = read_model(d).unwrap();
        assert_eq!(r.cameras[0].params, vec![90.0, 91.0, 50.0, 40.0]);
        let names: Vec<&str> = r.images.iter().map(|i| i.name.as_str()).collect();
        assert_eq!(names, ["x.jpg", "y.jpg", "z.jpg"]);
        assert_eq!(r.images[1].tvec, [1.0, 2.0, 3.0]);
        assert!(r.points.is_empty());
    }

    #[test]
    fn truncated_and_hostile_binary_files_are_errors() {
        let d_dir = tmp("hostile");
        let d = d_dir.path();
        write_model_bin(d, &sample()).unwrap();
        for (f, read) in [
            ("cameras.bin", (|p: &Path| read_cameras_bin(p).map(|_| ())) as fn(&Path) -> Result<(), ParseError>),
            ("images.bin", |p: &Path| read_images_bin(p).map(|_| ())),
            ("points3D.bin", |p: &Path| read_points_bin(p).map(|_| ())),
        ] {
            let full = std::fs::read(d.join(f)).unwrap();
            let cut = d.join(format!("cut-{f}"));
            for n in 0..full.len() {
                std::fs::write(&cut, &full[..n]).unwrap();
                assert!(read(&cut).is_err(), "{f} cut at {n} bytes");
            }
            let mut long = full.clone();
            long.push(0);
            std::fs::write(&cut, &long).unwrap();
            assert!(read(&cut).unwrap_err().msg.contains("unexpected bytes"));
        }
        // a huge count in a tiny file
        std::fs::write(d.join("huge.bin"), u64::MAX.to_le_bytes()).unwrap();
        assert!(read_points_bin(&d.join("huge.bin")).unwrap_err().msg.contains("does not fit"));
        // unknown model id and name
        let mut c = std::fs::read(d.join("cameras.bin")).unwrap();
        c[12..16].copy_from_slice(&99i32.to_le_bytes());
        std::fs::write(d.join("cameras.bin"), &c).unwrap();
        assert!(read_cameras_bin(&d.join("cameras.bin")).unwrap_err().msg.contains("unknown camera model id 99"));
        std::fs::write(d.join("cameras.txt"), "1 WEIRD 10 10 1 2 3\n").unwrap();
        assert!(read_cameras_txt(&d.join("cameras.txt")).unwrap_err().msg.contains("unknown camera model WEIRD"));
        // non-finite values and a camera the images do not know
        std::fs::write(d.join("cameras.txt"), "1 PINHOLE 10 10 NaN 2 3 4\n").unwrap();
        assert!(read_cameras_txt(&d.join("cameras.txt")).unwrap_err().msg.contains("non-finite"));
        let t_dir = tmp("orphan");
        let t = t_dir.path();
        let mut s = sample();
        s.images[0].camera_id = 9;
        write_model_txt(t, &s).unwrap();
        let e = read_model(t).unwrap_err();
        assert!(e.msg.contains("camera 9 is not in the cameras file") && e.msg.contains("a b.jpg"), "{e}");
    }
}
