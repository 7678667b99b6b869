//! COLMAP's text model files (`cameras.txt`, `images.txt`, `points3D.txt`),
//! read line by line with every field checked, and written.

use super::*;

/// The lines of a text model that are not comments (`#` after any
/// leading blanks, as COLMAP trims each line) with their line numbers.
pub(super) fn text_lines(path: &Path, bytes: &[u8]) -> Result<Vec<(usize, String)>, ParseError> {
    let text = std::str::from_utf8(bytes).map_err(|_| err(path, "not UTF-8 text"))?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    Ok(text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.to_string()))
        .filter(|(_, l)| !l.trim_start().starts_with('#'))
        .collect())
}

pub(super) fn field<T: std::str::FromStr>(
    path: &Path,
    line: usize,
    tok: Option<&str>,
    what: &str,
) -> Result<T, ParseError> {
    let tok = tok.ok_or_else(|| err(path, format!("line {line}: missing {what}")))?;
    tok.parse().map_err(|_| err(path, format!("line {line}: {what} '{tok}' is not a valid number")))
}

pub(super) fn finite_field(path: &Path, line: usize, tok: Option<&str>, what: &str) -> Result<f64, ParseError> {
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
    // blank lines kept: an image's 2-D points line may be empty
    let mut lines = text_lines(path, bytes)?.into_iter();
    let mut out = Vec::new();
    let mut seen = HashSet::new();
    while let Some((ln, l)) = lines.next() {
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
                return Err(err(path, format!("line {j}: 2-D points are not (x, y, point id) triples")));
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
    crate::util::atomic::write(&model_dir.join("cameras.txt"), &c)?;
    crate::util::atomic::write(&model_dir.join("images.txt"), &im)?;
    crate::util::atomic::write(&model_dir.join("points3D.txt"), &p)
}
