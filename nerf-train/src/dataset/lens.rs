//! Lens distortion of real cameras (the models of COLMAP and OpenCV), so
//! that a training or evaluation ray goes through the scene point a pixel
//! of the photo actually saw.
//!
//! Coordinates are normalised image coordinates in OpenCV's convention:
//! `x = (u − cx) / fx`, `y = (v − cy) / fy` with `u` right and `v` down, in
//! f64. [`Lens::distort`] maps an ideal pinhole point to where the lens
//! puts it; [`Lens::undistort`] inverts it by Newton's method.

/// A lens distortion model; coefficients act on normalised coordinates,
/// so they do not change when images are downscaled.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Lens {
    /// No distortion (an ideal pinhole).
    #[default]
    Pinhole,
    /// OpenCV's rational radial + tangential model (COLMAP `FULL_OPENCV`;
    /// `OPENCV`, `RADIAL`, `SIMPLE_RADIAL` and instant-ngp's `k1 k2 p1 p2`
    /// are this with the other coefficients 0):
    /// radial factor `(1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)`.
    Opencv {
        /// Radial coefficients `k1..k6` (`k4..k6` in the denominator).
        k: [f64; 6],
        /// Tangential coefficients `p1, p2`.
        p: [f64; 2],
    },
    /// OpenCV's fisheye model (COLMAP `OPENCV_FISHEYE`): the angle θ from
    /// the axis becomes `θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`.
    Fisheye {
        /// Coefficients `k1..k4`.
        k: [f64; 4],
    },
    /// COLMAP's `THIN_PRISM_FISHEYE`: the fisheye's equidistant point
    /// `(u, v) = (θ / r)(x, y)` scaled by `1 + k1 θ² + … + k4 θ⁸` as
    /// [`Lens::Fisheye`], plus OpenCV's tangential terms and the thin
    /// prism's `(s1 θ², s2 θ²)`, both evaluated on `(u, v)`.
    ThinPrismFisheye {
        /// Coefficients `k1..k4`.
        k: [f64; 4],
        /// Tangential coefficients `p1, p2`.
        p: [f64; 2],
        /// Thin-prism coefficients `sx1, sy1`.
        s: [f64; 2],
    },
    /// COLMAP's `FOV` (Devernay & Faugeras 2001): a point at radius `r`
    /// lands at `atan(2 r tan(ω/2)) / ω`; `ω → 0` is the pinhole.
    Fov {
        /// The field of view `ω`, radians.
        omega: f64,
    },
}

impl Lens {
    /// The OpenCV model from `k1, k2, p1, p2` (the others 0), or
    /// [`Lens::Pinhole`] if all are 0.
    pub fn opencv(k1: f64, k2: f64, p1: f64, p2: f64) -> Self {
        Self::Opencv { k: [k1, k2, 0.0, 0.0, 0.0, 0.0], p: [p1, p2] }.simplified()
    }

    /// [`Lens::Pinhole`] for an OpenCV lens whose coefficients are all 0 or
    /// a FOV lens with `ω = 0`, [`Lens::Fisheye`] for a thin-prism fisheye
    /// without tangential and prism terms, else `self`: a fisheye with all
    /// its coefficients 0 stays a fisheye (the equidistant projection,
    /// `r = θ`, which no pinhole images).
    pub fn simplified(self) -> Self {
        match self {
            Lens::Opencv { k, p } if k.iter().chain(&p).all(|&c| c == 0.0) => Lens::Pinhole,
            Lens::Fov { omega: 0.0 } => Lens::Pinhole,
            Lens::ThinPrismFisheye { k, p, s } if p.iter().chain(&s).all(|&c| c == 0.0) => Lens::Fisheye { k },
            _ => self,
        }
    }

    /// True if every coefficient is finite.
    pub fn is_finite(&self) -> bool {
        match self {
            Lens::Pinhole => true,
            Lens::Opencv { k, p } => k.iter().chain(p).all(|c| c.is_finite()),
            Lens::Fisheye { k } => k.iter().all(|c| c.is_finite()),
            Lens::ThinPrismFisheye { k, p, s } => k.iter().chain(p).chain(s).all(|c| c.is_finite()),
            Lens::Fov { omega } => omega.is_finite(),
        }
    }

    /// Where the lens images the ideal (pinhole) normalised point `(x, y)`.
    pub fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        match *self {
            Lens::Pinhole => (x, y),
            Lens::Opencv { k, p } => {
                let r2 = x * x + y * y;
                let num = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
                let den = 1.0 + r2 * (k[3] + r2 * (k[4] + r2 * k[5]));
                let radial = num / den;
                let xd = x * radial + 2.0 * p[0] * x * y + p[1] * (r2 + 2.0 * x * x);
                let yd = y * radial + p[0] * (r2 + 2.0 * y * y) + 2.0 * p[1] * x * y;
                (xd, yd)
            }
            Lens::Fisheye { k } => {
                let r = (x * x + y * y).sqrt();
                if r < 1e-12 {
                    return (x, y);
                }
                let th = r.atan();
                let t2 = th * th;
                let thd = th * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
                (x * thd / r, y * thd / r)
            }
            Lens::ThinPrismFisheye { k, p, s } => {
                let (xr, yr) = Lens::Fisheye { k }.distort(x, y);
                // the equidistant point the tangential and prism terms act on
                let (u, v) = Lens::Fisheye { k: [0.0; 4] }.distort(x, y);
                let r2 = u * u + v * v;
                let du = 2.0 * p[0] * u * v + p[1] * (r2 + 2.0 * u * u) + s[0] * r2;
                let dv = 2.0 * p[1] * u * v + p[0] * (r2 + 2.0 * v * v) + s[1] * r2;
                (xr + du, yr + dv)
            }
            Lens::Fov { omega } => {
                let (r, c) = ((x * x + y * y).sqrt(), 2.0 * (0.5 * omega).tan());
                // atan(c r) / (r ω), c / ω at the centre
                let factor = match omega == 0.0 {
                    true => 1.0,
                    false if r * c.abs() < 1e-12 => c / omega,
                    false => (c * r).atan() / (r * omega),
                };
                (x * factor, y * factor)
            }
        }
    }

    /// The ideal normalised point that [`Lens::distort`] maps to `(xd, yd)`:
    /// in closed form for [`Lens::Fov`]; otherwise by Newton's method (at
    /// most 50 steps, stopping below 10⁻¹² normalised units) from the
    /// distorted point, from the angle solving the fisheye's polynomial, or
    /// for the thin-prism fisheye from its fisheye part's inverse. Returns
    /// `None` if it does not converge or the point lies beyond what the
    /// lens images (a point outside the region where the model is invertible).
    pub fn undistort(&self, xd: f64, yd: f64) -> Option<(f64, f64)> {
        match *self {
            Lens::Pinhole => Some((xd, yd)),
            Lens::Opencv { .. } => self.newton(xd, yd, (xd, yd)),
            // from the fisheye's own inverse, the tangential and prism terms being small
            Lens::ThinPrismFisheye { k, .. } => {
                self.newton(xd, yd, Lens::Fisheye { k }.undistort(xd, yd).unwrap_or((xd, yd)))
            }
            Lens::Fov { omega } => {
                let (rd, c) = ((xd * xd + yd * yd).sqrt(), 2.0 * (0.5 * omega).tan());
                if rd * omega.abs() >= std::f64::consts::FRAC_PI_2 {
                    return None;
                }
                // tan(rd ω) / (rd c), ω / c at the centre
                let factor = match omega == 0.0 {
                    true => 1.0,
                    false if rd * omega.abs() < 1e-12 => omega / c,
                    false => (rd * omega).tan() / (rd * c),
                };
                Some((xd * factor, yd * factor))
            }
            Lens::Fisheye { k } => {
                let rd = (xd * xd + yd * yd).sqrt();
                if rd < 1e-12 {
                    return Some((xd, yd));
                }
                // solve θ (1 + k1 θ² + …) = rd for θ ∈ [0, π/2)
                let f = |th: f64| {
                    let t2 = th * th;
                    th * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])))) - rd
                };
                let df = |th: f64| {
                    let t2 = th * th;
                    1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])))
                };
                let mut th = rd.min(1.5);
                for _ in 0..50 {
                    let e = f(th);
                    if e.abs() < 1e-12 {
                        break;
                    }
                    let d = df(th);
                    if !d.is_finite() || d.abs() < 1e-12 {
                        return None;
                    }
                    th -= e / d;
                }
                let ok = th.is_finite() && (0.0..std::f64::consts::FRAC_PI_2).contains(&th) && f(th).abs() < 1e-9;
                let r = th.tan();
                ok.then_some((xd * r / rd, yd * r / rd))
            }
        }
    }
}

impl Lens {
    /// The point [`Lens::distort`] maps to `(xd, yd)` by Newton's method
    /// from `start` (at most 50 steps, the Jacobian by central differences
    /// as COLMAP computes it), or `None` where it does not converge.
    fn newton(&self, xd: f64, yd: f64, start: (f64, f64)) -> Option<(f64, f64)> {
        let (mut x, mut y) = start;
        for _ in 0..50 {
            let (fx, fy) = self.distort(x, y);
            let (ex, ey) = (fx - xd, fy - yd);
            if ex.abs().max(ey.abs()) < 1e-12 {
                return Some((x, y));
            }
            let h = 1e-7 * (1.0 + x.abs().max(y.abs()));
            let (ax, ay) = self.distort(x + h, y);
            let (bx, by) = self.distort(x - h, y);
            let (cx, cy) = self.distort(x, y + h);
            let (dx, dy) = self.distort(x, y - h);
            let (j00, j10) = ((ax - bx) / (2.0 * h), (ay - by) / (2.0 * h));
            let (j01, j11) = ((cx - dx) / (2.0 * h), (cy - dy) / (2.0 * h));
            let det = j00 * j11 - j01 * j10;
            if !det.is_finite() || det.abs() < 1e-12 {
                return None;
            }
            x -= (j11 * ex - j01 * ey) / det;
            y -= (-j10 * ex + j00 * ey) / det;
            if !x.is_finite() || !y.is_finite() {
                return None;
            }
        }
        let (fx, fy) = self.distort(x, y);
        ((fx - xd).abs().max((fy - yd).abs()) < 1e-9).then_some((x, y))
    }
}

/// A pinhole camera's intrinsics in pixels (OpenCV convention: `u` right,
/// `v` down, pixel centres at `+0.5`).
#[derive(Clone, Copy, Debug)]
pub struct Pixels {
    /// Focal lengths.
    pub fx: f64,
    /// Focal lengths.
    pub fy: f64,
    /// Principal point.
    pub cx: f64,
    /// Principal point.
    pub cy: f64,
}

/// Where `lens` puts the ideal point of the pinhole photo's pixel `(u, v)`:
/// the position in the photo, pixels from its top-left corner.
fn source(u: usize, v: usize, k: Pixels, lens: Lens) -> (f64, f64) {
    let (x, y) = ((u as f64 + 0.5 - k.cx) / k.fx, (v as f64 + 0.5 - k.cy) / k.fy);
    let (xd, yd) = lens.distort(x, y);
    (xd * k.fx + k.cx, yd * k.fy + k.cy)
}

/// The bilinear sample of a `w × h` photo (row-major, read through `at`) at
/// `(sx, sy)` (pixels from its top-left corner), clamped at the borders.
fn bilinear(at: impl Fn(usize, usize) -> [f32; 3], w: usize, h: usize, sx: f64, sy: f64) -> [f32; 3] {
    // position in pixel-centre units, clamped to the photo
    let su = (sx - 0.5).clamp(0.0, (w - 1) as f64);
    let sv = (sy - 0.5).clamp(0.0, (h - 1) as f64);
    let (u0, v0) = (su.floor() as usize, sv.floor() as usize);
    let (a, b) = ((su - u0 as f64) as f32, (sv - v0 as f64) as f32);
    let (p00, p10, p01, p11) = (at(u0, v0), at(u0 + 1, v0), at(u0, v0 + 1), at(u0 + 1, v0 + 1));
    std::array::from_fn(|c| (p00[c] * (1.0 - a) + p10[c] * a) * (1.0 - b) + (p01[c] * (1.0 - a) + p11[c] * a) * b)
}

/// The mask of the pinhole photo [`undistort_image`] makes of a `w × h`
/// photo whose own mask is `mask` (row-major, true where kept; empty: every
/// pixel kept): a pixel is kept if the lens imaged it (its ideal point lies
/// within the photo's pixels' extent; the others repeat the photo's
/// nearest edge) and every photo pixel it blends (weight above 10⁻⁴) is kept.
///
/// # Panics
/// If `mask` is not empty and holds fewer than `w × h` values.
pub fn undistort_mask(mask: &[bool], w: usize, h: usize, k: Pixels, lens: Lens) -> Vec<bool> {
    let at = |x: usize, y: usize| [mask[y.min(h - 1) * w + x.min(w - 1)] as u8 as f32; 3];
    let mut out = Vec::with_capacity(w * h);
    for v in 0..h {
        for u in 0..w {
            let (sx, sy) = source(u, v, k, lens);
            let imaged = (0.0..=w as f64).contains(&sx) && (0.0..=h as f64).contains(&sy);
            out.push(imaged && (mask.is_empty() || bilinear(at, w, h, sx, sy)[0] > 0.9999));
        }
    }
    out
}

/// The photo `rgb` (`w × h`, row-major) as an ideal pinhole camera with the
/// same intrinsics would have taken it: each output pixel's ideal point is
/// distorted by `lens` and the photo sampled there bilinearly (clamped at
/// the borders, so pixels the lens did not image, [`undistort_mask`], repeat the
/// nearest edge). COLMAP's `image_undistorter` does the same, cropping
/// those borders.
///
/// # Panics
/// If `rgb` holds fewer than `w × h` pixels.
pub fn undistort_image(rgb: &[[f32; 3]], w: usize, h: usize, k: Pixels, lens: Lens) -> Vec<[f32; 3]> {
    let at = |x: usize, y: usize| rgb[y.min(h - 1) * w + x.min(w - 1)];
    let mut out = Vec::with_capacity(w * h);
    for v in 0..h {
        for u in 0..w {
            let (sx, sy) = source(u, v, k, lens);
            out.push(bilinear(at, w, h, sx, sy));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth pattern photographed through a lens (each pixel shows the
    /// pattern at its ideal point), undistorted at load, matches the
    /// pinhole photo of the pattern away from the borders.
    #[test]
    fn undistorting_a_photo_recovers_the_pinhole_photo() {
        let (w, h) = (96usize, 64usize);
        let k = Pixels { fx: 80.0, fy: 80.0, cx: 48.0, cy: 32.0 };
        let pattern =
            |x: f64, y: f64| [(0.5 + 0.4 * (6.0 * x).sin()) as f32, (0.5 + 0.4 * (5.0 * y).cos()) as f32, 0.5];
        let lens = Lens::opencv(-0.2, 0.05, 0.002, -0.001);
        let mut photo = Vec::new();
        let mut pinhole = Vec::new();
        for v in 0..h {
            for u in 0..w {
                let (xd, yd) = ((u as f64 + 0.5 - k.cx) / k.fx, (v as f64 + 0.5 - k.cy) / k.fy);
                let (x, y) = lens.undistort(xd, yd).unwrap();
                photo.push(pattern(x, y));
                pinhole.push(pattern(xd, yd));
            }
        }
        let fixed = undistort_image(&photo, w, h, k, lens);
        let err = |img: &[[f32; 3]]| {
            let mut worst = 0.0f32;
            for v in 8..h - 8 {
                for u in 8..w - 8 {
                    for c in 0..3 {
                        worst = worst.max((img[v * w + u][c] - pinhole[v * w + u][c]).abs());
                    }
                }
            }
            worst
        };
        let (before, after) = (err(&photo), err(&fixed));
        assert!(
            after < 0.01 && before > 20.0 * after,
            "largest difference from the pinhole photo: {before} before, {after} after"
        );
        assert_eq!(undistort_image(&photo, w, h, k, Lens::Pinhole), photo);
    }

    #[test]
    fn a_pincushion_lens_leaves_the_pinhole_photos_corners_unimaged() {
        let (w, h) = (64usize, 48usize);
        let k = Pixels { fx: 40.0, fy: 40.0, cx: 32.0, cy: 24.0 };
        assert!(undistort_mask(&[], w, h, k, Lens::Pinhole).iter().all(|&i| i));
        // pincushion (k1 > 0) pushes the corners' ideal points out of the photo
        let pin = undistort_mask(&[], w, h, k, Lens::opencv(0.3, 0.0, 0.0, 0.0));
        assert!(!pin[0] && !pin[w - 1] && !pin[(h - 1) * w] && !pin[w * h - 1]);
        assert!(pin[(h / 2) * w + w / 2]);
        // barrel (k1 < 0) pulls them in: every pixel imaged
        assert!(undistort_mask(&[], w, h, k, Lens::opencv(-0.1, 0.0, 0.0, 0.0)).iter().all(|&i| i));
    }

    /// Pixels of a 640×480 camera, f = 500: project an ideal point,
    /// distort, undistort; the round trip returns within 1e-4 px.
    fn round_trip(lens: Lens) {
        let (f, cx, cy) = (500.0, 320.0, 240.0);
        let mut worst = 0.0f64;
        for v in (0..=480).step_by(16) {
            for u in (0..=640).step_by(16) {
                let (x, y) = ((u as f64 - cx) / f, (v as f64 - cy) / f);
                let (xd, yd) = lens.distort(x, y);
                let (ux, uy) = lens.undistort(xd, yd).expect("invertible inside the image");
                worst = worst.max(((ux - x) * f).abs()).max(((uy - y) * f).abs());
            }
        }
        assert!(worst < 1e-4, "{lens:?}: round trip error {worst} px");
    }

    #[test]
    fn opencv_round_trip_within_1e4_px() {
        // the fox capture's coefficients, then stronger barrel and pincushion
        round_trip(Lens::opencv(0.0578421, -0.0805099, -0.000980296, 0.00015575));
        round_trip(Lens::opencv(-0.25, 0.05, 0.001, -0.002));
        round_trip(Lens::Opencv { k: [0.1, 0.02, 0.003, 0.05, 0.01, 0.002], p: [0.002, -0.001] });
    }

    #[test]
    fn fisheye_round_trip_within_1e4_px() {
        round_trip(Lens::Fisheye { k: [0.05, -0.01, 0.002, -0.0005] });
        round_trip(Lens::Fisheye { k: [-0.1, 0.01, 0.0, 0.0] });
    }

    #[test]
    fn thin_prism_fisheye_and_fov_round_trip_within_1e4_px() {
        round_trip(Lens::ThinPrismFisheye { k: [0.05, -0.01, 0.002, -0.0005], p: [0.001, -0.002], s: [0.002, 0.001] });
        round_trip(Lens::Fov { omega: 0.9 });
        round_trip(Lens::Fov { omega: -0.5 });
        round_trip(Lens::Fov { omega: 0.0 });
    }

    #[test]
    fn thin_prism_and_fov_lenses_move_points_as_colmap_does() {
        // the prism terms alone: the equidistant point (θ/r)(x, y) shifted by (s1 θ², s2 θ²)
        let lens = Lens::ThinPrismFisheye { k: [0.0; 4], p: [0.0; 2], s: [0.01, -0.02] };
        let th = 0.5f64.atan();
        let (x, y) = lens.distort(0.5, 0.0);
        assert!((x - (th + 0.01 * th * th)).abs() < 1e-15 && (y + 0.02 * th * th).abs() < 1e-15, "{x} {y}");
        // the tangential terms alone, as OpenCV's on the equidistant point (u, v) = (θ/r)(x, y)
        let lens = Lens::ThinPrismFisheye { k: [0.0; 4], p: [0.01, -0.02], s: [0.0; 2] };
        let (r, t) = ((0.3f64 * 0.3 + 0.4 * 0.4).sqrt(), (0.3f64 * 0.3 + 0.4 * 0.4).sqrt().atan());
        let (u, v) = (0.3 * t / r, 0.4 * t / r);
        let (x, y) = lens.distort(0.3, 0.4);
        let want = (
            u + 2.0 * 0.01 * u * v - 0.02 * (t * t + 2.0 * u * u),
            v - 2.0 * 0.02 * u * v + 0.01 * (t * t + 2.0 * v * v),
        );
        assert!((x - want.0).abs() < 1e-15 && (y - want.1).abs() < 1e-15, "{x} {y} {want:?}");
        // FOV: a point at radius r lands at atan(2 r tan(ω/2)) / ω
        let omega = 0.9f64;
        let (x, _) = Lens::Fov { omega }.distort(0.5, 0.0);
        assert!((x - (2.0 * 0.5 * (omega / 2.0).tan()).atan() / omega).abs() < 1e-15);
        // beyond the field of view FOV images nothing: no ideal point
        assert_eq!(Lens::Fov { omega }.undistort(std::f64::consts::FRAC_PI_2 / omega + 0.01, 0.0), None);
        assert_eq!(Lens::Fov { omega: 0.0 }.simplified(), Lens::Pinhole);
    }

    #[test]
    fn distortion_moves_points_as_the_coefficients_say() {
        // k1 > 0 pushes points outwards (pincushion), k1 < 0 inwards (barrel)
        let (x, _) = Lens::opencv(0.1, 0.0, 0.0, 0.0).distort(0.5, 0.0);
        assert!((x - 0.5 * (1.0 + 0.1 * 0.25)).abs() < 1e-15);
        let (x, _) = Lens::opencv(-0.1, 0.0, 0.0, 0.0).distort(0.5, 0.0);
        assert!(x < 0.5);
        assert_eq!(Lens::opencv(0.0, 0.0, 0.0, 0.0), Lens::Pinhole);
        assert_eq!(Lens::Pinhole.distort(0.3, -0.2), (0.3, -0.2));
    }

    #[test]
    fn a_fisheye_without_coefficients_is_the_equidistant_projection_not_a_pinhole() {
        let lens = Lens::Fisheye { k: [0.0; 4] };
        assert_eq!(lens.simplified(), lens);
        // a point 45° off the axis (x = tan 45° = 1) lands at r = θ = π/4
        let (x, y) = lens.distort(1.0, 0.0);
        assert!((x - core::f64::consts::FRAC_PI_4).abs() < 1e-15 && y == 0.0, "{x} {y}");
        round_trip(lens);
    }
}
