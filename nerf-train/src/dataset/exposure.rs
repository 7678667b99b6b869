//! Whether a capture's photos differ in exposure, measured on the photos
//! themselves at the capture's sparse points: a point's brightness in each
//! training photo that sees it, against its median over those photos. A
//! photo's gain is the median of those ratios over its points; a capture
//! whose gains spread widely (auto exposure, changing light) is one for
//! the per-photo colour correction (`per_photo.appearance`).

use super::fit::Pose;
use glam::DVec3;

/// Points sampled from the capture's sparse points, at most (every k-th).
pub const MAX_POINTS: usize = 2000;

/// Photos a point must be seen by to count.
pub const MIN_VIEWS: usize = 3;

/// Points a photo must see to get a gain.
pub const MIN_POINTS: usize = 20;

/// Darkest median brightness (stored values, in `[0, 1]`) of a point that
/// counts: ratios of near-black pixels are noise.
pub const MIN_BRIGHTNESS: f32 = 0.05;

/// The spread of the photos' gains (the 90th over the 10th percentile)
/// above which [`note`] speaks.
pub const SPREAD: f64 = 1.25;

/// A training photo as loaded: its camera (capture space, at the photo's
/// full size `size`) and its pixels at `width × height` (stored values,
/// row-major).
pub struct Loaded<'a> {
    /// Camera-to-world pose, OpenGL axes, capture units.
    pub pose: Pose,
    /// Focal lengths along x and y, full-size pixels.
    pub focal: [f64; 2],
    /// Principal point from the top-left corner, full-size pixels.
    pub centre: [f64; 2],
    /// The full width and height `focal` and `centre` refer to.
    pub size: [f64; 2],
    /// The loaded photo's width in pixels.
    pub width: u32,
    /// The loaded photo's height in pixels.
    pub height: u32,
    /// Its pixels.
    pub rgb: &'a [[f32; 3]],
}

/// Each photo's gain at the sparse `points` (capture space): the median,
/// over the points it sees (in front of it, inside its frame, seen by at
/// least [`MIN_VIEWS`] photos, of median brightness at least
/// [`MIN_BRIGHTNESS`]), of its brightness there (the mean of the three
/// stored channels at the nearest pixel) over the point's median across
/// the photos; `None` for a photo with fewer than [`MIN_POINTS`] such
/// points. Pinhole projection: the lens is left out (its shift is a few
/// pixels at the edges of a photo at the sizes trained on).
pub fn gains(photos: &[Loaded<'_>], points: &[DVec3]) -> Vec<Option<f64>> {
    let step = points.len().div_ceil(MAX_POINTS).max(1);
    let sample: Vec<DVec3> = points.iter().step_by(step).copied().collect();
    // brightness of each sampled point in each photo, NaN where the photo does not see it
    let seen: Vec<Vec<f32>> = photos.iter().map(|p| sample.iter().map(|&q| brightness(p, q)).collect()).collect();
    let medians: Vec<Option<f32>> = (0..sample.len())
        .map(|j| {
            let mut v: Vec<f32> = seen.iter().map(|s| s[j]).filter(|b| !b.is_nan()).collect();
            (v.len() >= MIN_VIEWS).then(|| median(&mut v)).filter(|&m| m >= MIN_BRIGHTNESS)
        })
        .collect();
    seen.iter()
        .map(|s| {
            let mut r: Vec<f32> =
                s.iter().zip(&medians).filter_map(|(&b, m)| m.filter(|_| !b.is_nan()).map(|m| b / m)).collect();
            (r.len() >= MIN_POINTS).then(|| median(&mut r) as f64)
        })
        .collect()
}

/// What to tell the user about `gains` ([`gains`]) of the photos of the
/// capture at `path`: a sentence when the 90th percentile of the gains is
/// more than [`SPREAD`] times the 10th, none otherwise (or with fewer
/// than 3 photos measured).
pub fn note(path: &std::path::Path, gains: &[Option<f64>]) -> Option<String> {
    let mut g: Vec<f64> = gains.iter().flatten().copied().collect();
    if g.len() < 3 {
        return None;
    }
    g.sort_by(f64::total_cmp);
    let at = |q: f64| g[((g.len() - 1) as f64 * q).round() as usize];
    let (lo, hi) = (at(0.1), at(0.9));
    (hi > SPREAD * lo).then(|| {
        format!(
            "{}: the photos differ in exposure: at the same sparse points their brightness spans ×{lo:.2} to \
             ×{hi:.2} of the points' median (10th to 90th percentile of {} photos); a --config file holding \
             {{\"per_photo\": {{\"appearance\": true}}}} fits a colour correction per photo: train with and without it \
             and compare the two with nerf eval",
            path.display(),
            g.len()
        )
    })
}

/// The brightness of photo `p` at the point `q`, NaN where it does not see it.
fn brightness(p: &Loaded<'_>, q: DVec3) -> f32 {
    let (r, eye) = p.pose;
    let d = q - eye;
    let z = -d.dot(r.z_axis);
    if z <= 1e-9 {
        return f32::NAN;
    }
    let (x, y) = (d.dot(r.x_axis) / z, -d.dot(r.y_axis) / z);
    // full-size pixel coordinates, then the loaded photo's
    let u = (p.centre[0] + p.focal[0] * x) * p.width as f64 / p.size[0];
    let v = (p.centre[1] + p.focal[1] * y) * p.height as f64 / p.size[1];
    if !(0.0..p.width as f64).contains(&u) || !(0.0..p.height as f64).contains(&v) {
        return f32::NAN;
    }
    // the mean over the 3×3 pixels about it: a point on a texture is not
    // one pixel's brightness a pixel off
    let (w, h) = (p.width as usize, p.height as usize);
    let (x, y) = (u as usize, v as usize);
    let mut sum = 0.0;
    for yy in y.saturating_sub(1)..(y + 2).min(h) {
        for xx in x.saturating_sub(1)..(x + 2).min(w) {
            let c = p.rgb[yy * w + xx];
            sum += (c[0] + c[1] + c[2]) / 3.0;
        }
    }
    let n = (y + 2).min(h) - y.saturating_sub(1);
    let m = (x + 2).min(w) - x.saturating_sub(1);
    sum / (n * m) as f32
}

/// The median of `v` (not empty; reordered).
fn median(v: &mut [f32]) -> f32 {
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}
