//! The integer-only fixed-point path: after a per-ray setup that converts
//! the ray once, no float operation per sample. `t` and `δ` in Q16,
//! positions in Q24, density in Q10, colours in Q15, weights and
//! transmittance in Q30 (the table is in [`crate::fixed`]). One path, two
//! kernels: int16 weights ([`W16`]) and int8 weights ([`W8`]).

use super::march::render;
use super::path::NumericPath;
use super::renderer::{Dispatch, Renderer};
use super::scratch::Scratch;
use crate::camera::{Ray, FOOTPRINT_POINTS};
use crate::composite::{CompositorFixed, PixelFixed, DELTA_INF_Q16};
use crate::encoding::NPOS_FRAC;
use crate::error::{Error, Result};
use crate::fixed::{sat_i32, shr_round_i64, to_fixed, POS_FRAC, T_ONE};
use crate::format::{Model, Scheme};
use crate::network::{check_i8_headroom, Fixed, W16, W8};
use crate::occupancy::{CoarseOccupancy, Occupancy};
use crate::proposal::Proposal;
use crate::sampling::{sample_pdf_fixed, stratified_fixed, stratified_fixed_from};
use crate::unbounded::{contract_q24, s_of_t_q30, t_of_s_q16};
use glam::Vec3;

/// A ray in the fixed-point path's formats.
#[derive(Clone, Copy, Debug)]
pub struct RayFixed {
    origin: [i32; 3], // Q24 normalised
    dir: [i32; 3],    // Q24 normalised per unit t
    viewdir: [i32; 3],
    dir_len: i32,                               // Q16
    near: i32,                                  // Q16
    far: i32,                                   // Q16
    linear_until: Option<i32>,                  // Q16: unbounded scene (contracted positions, spaced samples)
    foot: Option<[[i32; 3]; FOOTPRINT_POINTS]>, // Q24 normalised per unit t: the footprint's offsets
}

impl RayFixed {
    fn new(r: &Ray) -> Self {
        let q24 = |v: Vec3| v.to_array().map(|x| to_fixed(x, NPOS_FRAC));
        Self {
            origin: q24(r.norm_origin),
            dir: q24(r.norm_dir),
            viewdir: q24(r.viewdir),
            dir_len: to_fixed(r.dir_len, POS_FRAC),
            near: to_fixed(r.near, POS_FRAC),
            far: to_fixed(r.far, POS_FRAC),
            linear_until: r.linear_until.map(|t| to_fixed(t, POS_FRAC).max(1)),
            foot: r.foot.map(|f| f.map(q24)),
        }
    }

    /// The footprint's Q24 points at Q16 parameter `t` (as
    /// [`Ray::foot_at`]), or `None` for a line.
    #[inline(always)]
    fn foot_at(&self, t: i32) -> Option<[[i32; 3]; FOOTPRINT_POINTS]> {
        let foot = self.foot?;
        let p: [i64; 3] =
            core::array::from_fn(|c| self.origin[c] as i64 + shr_round_i64(t as i64 * self.dir[c] as i64, POS_FRAC));
        let pts: [[i64; 3]; FOOTPRINT_POINTS] =
            foot.map(|f| core::array::from_fn(|c| p[c] + shr_round_i64(t as i64 * f[c] as i64, POS_FRAC)));
        Some(pts.map(|u| match self.linear_until {
            None => u.map(sat_i32),
            Some(_) => contract_q24(u),
        }))
    }

    /// Q24 position at Q16 parameter `t` (saturating; contracted in an unbounded scene).
    #[inline(always)]
    fn at(&self, t: i32) -> [i32; 3] {
        let u =
            core::array::from_fn(|c| self.origin[c] as i64 + shr_round_i64(t as i64 * self.dir[c] as i64, POS_FRAC));
        match self.linear_until {
            None => u.map(sat_i32),
            Some(_) => contract_q24(u),
        }
    }

    /// The `out.len()` stratified samples of `near..far` (Q16), spaced as
    /// the scene says (see [`Ray::stratified`]).
    fn stratified(&self, key: Option<u32>, out: &mut [i32]) {
        match self.linear_until {
            None => stratified_fixed(self.near, self.far, key, out),
            Some(lin) => {
                stratified_fixed(s_of_t_q30(self.near, lin), s_of_t_q30(self.far, lin), key, out);
                out.iter_mut().for_each(|s| *s = t_of_s_q16(*s, lin));
            }
        }
    }
}

impl NumericPath for Fixed {
    type T = i32;
    type W = u32;
    type Cdf = u64;
    type Ray = RayFixed;
    type Compositor = CompositorFixed;
    type Pixel = PixelFixed;

    fn check(model: &Model<'_>) -> Result<()> {
        if !model.scheme().is_fixed() {
            return Err(Error::WrongNumericPath(model.scheme()));
        }
        check_i8_headroom(model, &model.coarse)?;
        if let Some(f) = &model.fine {
            check_i8_headroom(model, f)?;
        }
        Ok(())
    }

    fn early_stop(e: f32) -> u32 {
        (e as f64 * T_ONE as f64) as u32
    }

    fn t(t: f32) -> i32 {
        to_fixed(t, POS_FRAC)
    }

    fn span(lo: f32, hi: f32) -> (i32, i32) {
        // Q16, widened outward (saturating casts; the box margin covers rounding)
        (libm::floorf(lo * 65536.0) as i32, libm::ceilf(hi * 65536.0) as i32)
    }

    fn ray(r: &Ray) -> RayFixed {
        RayFixed::new(r)
    }

    #[inline(always)]
    fn at(ray: &RayFixed, t: i32) -> [i32; 3] {
        ray.at(t)
    }

    #[inline(always)]
    fn foot_at(ray: &RayFixed, t: i32) -> Option<[[i32; 3]; FOOTPRINT_POINTS]> {
        ray.foot_at(t)
    }

    #[inline(always)]
    fn cell(grid: &Occupancy<'_>, p: [i32; 3]) -> [usize; 3] {
        grid.cell_fixed(p, NPOS_FRAC)
    }

    fn sigma(s: f32) -> i32 {
        // at most 1e6 · 2^10 < 2^31
        libm::roundf(s.clamp(0.0, crate::proposal::MAX_PROPOSAL_SIGMA) * 1024.0) as i32
    }

    #[inline(always)]
    fn proposal_code(g: &Proposal<'_>, p: [i32; 3]) -> u8 {
        g.code_fixed(p, NPOS_FRAC)
    }

    #[inline(always)]
    fn occupied(grid: &Occupancy<'_>, p: [i32; 3]) -> bool {
        grid.at_fixed(p, NPOS_FRAC)
    }

    fn run_len(coarse: &CoarseOccupancy, ray: &RayFixed, t: &[i32]) -> usize {
        let n = t.len();
        let spacing = if n > 1 { (t[n - 1] as i64 - t[0] as i64) / (n - 1) as i64 } else { 0 };
        let fastest = ray.dir.iter().map(|d| d.unsigned_abs() as u64).max().unwrap_or(0);
        coarse.run_len((spacing.max(0) as u64 * fastest) >> 16)
    }

    #[inline(always)]
    fn delta(ray: &RayFixed, t: &[i32], i: usize) -> i32 {
        if i + 1 < t.len() {
            let dt = t[i + 1] as i64 - t[i] as i64;
            shr_round_i64(dt * ray.dir_len as i64, POS_FRAC).clamp(0, DELTA_INF_Q16 as i64 - 1) as i32
        } else {
            DELTA_INF_Q16
        }
    }

    fn samples(ray: &RayFixed, key: Option<u32>, out: &mut [i32]) {
        ray.stratified(key, out);
    }

    /// The `n` stratified samples of `ray` that a pass over `span` (Q16) can
    /// use, written to `out`: from the last one before `span.0` to the first one
    /// after `span.1` (or the end). The pass reads the same samples and deltas
    /// as over all `n` (the one after the span bounds the last delta, and the
    /// one before it confirms that no earlier sample is inside), so the pixel is
    /// bit-identical; only their generation is saved.
    fn samples_around<'o>(
        ray: &RayFixed,
        n: usize,
        key: Option<u32>,
        span: (i32, i32),
        out: &'o mut [i32],
    ) -> &'o [i32] {
        let (near, len) = (ray.near as i64, (ray.far as i64 - ray.near as i64).max(0));
        // an unbounded scene's samples are not evenly spaced in `t` (and its span is the whole ray)
        if n < 3 || len == 0 || ray.linear_until.is_some() {
            ray.stratified(key, &mut out[..n]);
            return &out[..n];
        }
        // unjittered index of a Q16 parameter, rounded down; jitter moves a
        // sample by less than one stratum, so one more on each side is enough
        let d = (n - 1) as i64;
        let index = |t: i32| ((t as i64 - near).clamp(0, len) * d / len) as usize;
        let first = index(span.0).saturating_sub(1);
        let end = (index(span.1) + 3).min(n);
        let part = &mut out[..end - first];
        stratified_fixed_from(ray.near, ray.far, n, key, first, part);
        let starts_before = first == 0 || part[0] < span.0;
        let ends_after = end == n || part[part.len() - 1] > span.1;
        if starts_before && ends_after {
            return &out[..end - first];
        }
        // not reached for valid rays; kept so the result never depends on it
        stratified_fixed(ray.near, ray.far, key, &mut out[..n]);
        &out[..n]
    }

    fn sample_pdf(t: &[i32], w: &[u32], u_q16: impl Fn(usize) -> u32, cdf: &mut [u64], out: &mut [i32]) {
        sample_pdf_fixed(t, w, u_q16, cdf, out);
    }

    fn viewdir(ray: &RayFixed) -> [i32; 3] {
        ray.viewdir
    }
}

/// int16 or int8 weights, as the model holds.
impl Dispatch for Fixed {
    fn render<const B: usize>(
        r: &Renderer<'_, '_, Fixed>,
        ray: &Ray,
        key: Option<u32>,
        s: &mut Scratch<Fixed, B>,
    ) -> PixelFixed {
        match r.model.scheme() {
            Scheme::I16 => render::<Fixed, W16, B>(r, ray, key, s),
            Scheme::I8 => render::<Fixed, W8, B>(r, ray, key, s),
            // (`RendererFixed::new` refuses f32 models: never reached)
            Scheme::F32 => r.background(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::{Scene, Unbounded, MAX_COARSE, MAX_MARCH};
    use crate::sampling::hash32;

    /// The fixed path's footprint points are the f32 path's to within the
    /// rounding of Q24 positions, centred on the ray at a radius `ρ·t`, in
    /// bounded and unbounded scenes; forward-facing rays have none.
    #[test]
    fn footprint_points_agree_across_paths_and_surround_the_sample() {
        let u = |k: u32| hash32(k) as f32 / u32::MAX as f32;
        let mut unb = Scene::blender(1.5, 0.5, 40.0);
        unb.unbounded = Some(Unbounded { linear_until: 2.0 });
        for (case, scene) in [Scene::blender(1.5, 2.0, 6.0), unb].iter().enumerate() {
            let mut checked = 0;
            for k in 0..200u32 {
                let k = k * 8 + case as u32 * 5000;
                let o = Vec3::new(2.0 * u(k) - 1.0, 2.0 * u(k + 1) - 1.0, 4.0);
                let d = Vec3::new(u(k + 2) - 0.5, u(k + 3) - 0.5, -1.0);
                let pixel = 0.001 + 0.01 * u(k + 4);
                let Some(ray) = Ray::new(scene, o, d) else { continue };
                let ray = ray.with_footprint(scene, pixel, 6.0 * u(k + 5));
                let rf = RayFixed::new(&ray);
                let t = ray.near + (ray.far - ray.near) * u(k + 6);
                let tq = to_fixed(t, POS_FRAC);
                let (pf, pq) = (ray.foot_at(tq as f32 / 65536.0).unwrap(), rf.foot_at(tq).unwrap());
                for (a, b) in pf.iter().zip(&pq) {
                    for c in 0..3 {
                        let err = (a[c] - b[c] as f32 / (1 << NPOS_FRAC) as f32).abs();
                        assert!(err < 1e-5 * (1.0 + a[c].abs()), "case {case} ray {k}: {a:?} against {b:?}");
                    }
                }
                if scene.unbounded.is_none() {
                    // at ρ·t from the sample across the ray, in normalised units (bounds ±1.5)
                    let p = ray.at(tq as f32 / 65536.0);
                    let rho = pixel * crate::camera::FOOTPRINT_RADIUS * (tq as f32 / 65536.0) / 1.5;
                    for q in pf {
                        let off = Vec3::from(q) - p;
                        assert!((off.length() - rho).abs() < 1e-3 * rho + 1e-6, "{} against {rho}", off.length());
                        assert!(off.dot(ray.viewdir).abs() < 1e-3 * rho + 1e-6);
                    }
                }
                checked += 1;
            }
            assert!(checked > 100, "{checked} rays met the bounds");
        }
        let ff = Scene {
            ndc: Some(crate::format::Ndc { width: 8.0, height: 8.0, focal: 8.0 }),
            ..Scene::blender(1.0, 0.0, 1.0)
        };
        let ray = Ray::new(&ff, Vec3::ZERO, Vec3::new(0.1, 0.0, -1.0)).unwrap().with_footprint(&ff, 0.01, 0.0);
        assert!(ray.foot.is_none() && ray.foot_at(0.5).is_none());
    }

    /// What makes a pass over the samples around the span bit-identical to
    /// one over all of them: they are a contiguous run of the full set that
    /// holds every sample inside the span, begins before it (or at the
    /// first sample) and ends after it (or at the last).
    #[test]
    fn the_samples_around_the_span_are_a_run_of_the_full_set_covering_it() {
        let mut out = [0i32; MAX_MARCH];
        let mut full = [0i32; MAX_MARCH];
        let mut shortened = 0;
        for case in 0..4000u32 {
            let h = |k: u32| hash32(case.wrapping_mul(7919) ^ k);
            let near = (h(1) % (8 << 16)) as i32;
            let far = near + (h(2) % (8 << 16)) as i32;
            let n = [2, 3, 5, 64, 192, MAX_COARSE, 512, MAX_MARCH][(h(3) % 8) as usize];
            let key = (h(4) % 2 == 0).then(|| h(5));
            let a = near - (1 << 16) + (h(6) % (10 << 16)) as i32;
            let span = (a, a + (h(7) % (4 << 16)) as i32);
            let ray = RayFixed {
                origin: [0; 3],
                dir: [0; 3],
                viewdir: [0; 3],
                dir_len: 1 << 16,
                near,
                far,
                linear_until: None,
                foot: None,
            };
            stratified_fixed(near, far, key, &mut full[..n]);
            let part = Fixed::samples_around(&ray, n, key, span, &mut out);
            let len = part.len();
            let first = (0..=n - len).find(|&k| full[k..k + len] == *part);
            let first = first.unwrap_or_else(|| panic!("case {case}: not a run of the full set"));
            let end = first + len;
            assert!(first == 0 || part[0] < span.0, "case {case}: starts inside the span");
            assert!(end == n || part[len - 1] > span.1, "case {case}: ends inside the span");
            let inside = |t: &i32| (span.0..=span.1).contains(t);
            let all = full[..n].iter().filter(|t| inside(t)).count();
            assert_eq!(part.iter().filter(|t| inside(t)).count(), all, "case {case}");
            shortened += (len < n) as u32;
        }
        // and the point of it: most rays generate fewer samples
        assert!(shortened > 2000, "{shortened} of 4000 shortened");
    }
}
