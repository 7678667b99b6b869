//! Unbounded scenes ([`crate::format::Unbounded`]): the contraction that
//! fits all of space into the grid, and the spacing of samples along a ray
//! that reaches far beyond the bounds. The f32 functions are the reference;
//! the fixed-point ones follow them within the rounding stated on each.
//!
//! Contraction (mip-NeRF 360, eq. 10, with the max norm so that the bounds'
//! cube stays a cube): a normalised position `u` (bounds ↦ `[−1, 1]³`) with
//! `m = ‖u‖∞` becomes `u/2` for `m ≤ 1` and `u/m · (1 − 1/(2m))` beyond.
//! The bounds fill `[−½, ½]³`; everything beyond them the shell out to
//! `[−1, 1]³`, distance `m` landing at `1 − 1/(2m)`.
//!
//! Focus ([`crate::format::Focus`]): a per-axis piecewise-linear map `W`
//! of `[−1, 1]` onto itself that stretches the part of the bounds the
//! cameras look at. Inside the bounds `u` becomes `W(u)/2`; beyond them,
//! with `v = u/m`, `(v + (W(v) − v)/m) · (1 − 1/(2m))`: continuous at the
//! bounds, the max norm still `1 − 1/(2m)`, and the stretch fading with
//! distance so that far surroundings keep the plain contraction's cells.
//!
//! Spacing (Zip-NeRF's piecewise "linear then inverse"): a sample at `s ∈
//! [0, 1)` sits at `t = 2Ts` for `s < ½` and at `t = T/(2(1 − s))` beyond,
//! `T` being [`crate::format::Unbounded::linear_until`]: samples evenly
//! spaced in `s` are evenly spaced in `t` up to `T` and in `1/t` after it,
//! as the contraction spaces space.

use crate::format::Focus;
use glam::Vec3;

/// A [`Focus`] ready to apply: per axis the map `W`'s knots `−1, a, b, 1`
/// and their images `−1, a', b', 1`, and the slopes of its three pieces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Warp {
    from: [[f32; 2]; 3],
    to: [[f32; 2]; 3],
    slopes: [[f32; 3]; 3],
}

impl Warp {
    /// The map of a valid `focus` ([`Focus::is_valid`]: every slope within `1/64..=64`).
    pub fn new(focus: &Focus) -> Self {
        let slopes = core::array::from_fn(|k| {
            let ([a, b], [c, d]) = (focus.from[k], focus.to[k]);
            [(c + 1.0) / (a + 1.0), (d - c) / (b - a), (1.0 - d) / (1.0 - b)]
        });
        Self { from: focus.from, to: focus.to, slopes }
    }

    /// `W` and its slope along axis `k` at `v ∈ [−1, 1]`.
    #[inline]
    fn axis(&self, k: usize, v: f32) -> (f32, f32) {
        let ([a, b], [c, d], s) = (self.from[k], self.to[k], self.slopes[k]);
        if v < a {
            (-1.0 + (v + 1.0) * s[0], s[0])
        } else if v <= b {
            (c + (v - a) * s[1], s[1])
        } else {
            (d + (v - b) * s[2], s[2])
        }
    }

    /// `W(v)` per axis, `v ∈ [−1, 1]³`.
    #[inline]
    pub fn apply(&self, v: Vec3) -> Vec3 {
        Vec3::new(self.axis(0, v.x).0, self.axis(1, v.y).0, self.axis(2, v.z).0)
    }

    /// `W′(v)` per axis (the slope of the piece `v` lies on).
    #[inline]
    pub fn slope(&self, v: Vec3) -> Vec3 {
        Vec3::new(self.axis(0, v.x).1, self.axis(1, v.y).1, self.axis(2, v.z).1)
    }
}

/// Contracted position (in `[−1, 1]³`) of the normalised position `p`,
/// stretched by `warp` where a scene has a [`Focus`].
#[inline]
pub fn contract_f32(p: Vec3, warp: Option<&Warp>) -> Vec3 {
    let m = p.abs().max_element();
    match (m <= 1.0, warp) {
        (true, None) => 0.5 * p,
        (true, Some(w)) => 0.5 * w.apply(p),
        (false, None) => p * ((1.0 - 0.5 / m) / m),
        (false, Some(w)) => {
            let v = p / m;
            (v + (w.apply(v) - v) / m) * (1.0 - 0.5 / m)
        }
    }
}

/// `s ∈ [0, 1)` of the ray parameter `t ≥ 0` for `T = lin` (the inverse of [`t_of_s`]).
#[inline]
pub fn s_of_t(t: f32, lin: f32) -> f32 {
    let t = t.max(0.0);
    if t < lin {
        0.5 * t / lin
    } else {
        1.0 - 0.5 * lin / t
    }
}

/// The ray parameter `t` of `s ∈ [0, 1)` for `T = lin`.
#[inline]
pub fn t_of_s(s: f32, lin: f32) -> f32 {
    if s < 0.5 {
        2.0 * lin * s
    } else {
        0.5 * lin / (1.0 - s).max(f32::MIN_POSITIVE)
    }
}

/// 1 in Q24, the normalised positions' format.
const ONE_Q24: i64 = 1 << 24;
/// ½ in Q30, the fixed-point `s`.
const HALF_Q30: i64 = 1 << 29;

/// [`Warp`] in fixed point: knots and their images in Q24, slopes in Q24
/// (at most 64: below 2³⁰).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarpQ24 {
    from: [[i64; 2]; 3],
    to: [[i64; 2]; 3],
    slopes: [[i64; 3]; 3],
}

impl WarpQ24 {
    /// `w` rounded to Q24.
    pub fn new(w: &Warp) -> Self {
        let q = |v: f32| crate::fixed::to_fixed(v, 24) as i64;
        Self { from: w.from.map(|p| p.map(q)), to: w.to.map(|p| p.map(q)), slopes: w.slopes.map(|p| p.map(q)) }
    }

    /// `W(v)` along axis `k`, `v` in Q24 within `[−2²⁴, 2²⁴]`, products rounded half up.
    #[inline]
    fn axis(&self, k: usize, v: i64) -> i64 {
        let ([a, b], [c, d], s) = (self.from[k], self.to[k], self.slopes[k]);
        let lin = |base: i64, dv: i64, s: i64| base + ((dv * s + (1 << 23)) >> 24);
        if v < a {
            lin(-ONE_Q24, v + ONE_Q24, s[0])
        } else if v <= b {
            lin(c, v - a, s[1])
        } else {
            lin(d, v - b, s[2])
        }
    }
}

/// Fixed-point [`contract_f32`]: `u` in Q24 (any magnitude an i64 holds up
/// to 2⁶²), the result in Q24 within `[−2²⁴, 2²⁴]`. Inside the bounds the
/// halving rounds half up; beyond them the quotients truncate toward zero
/// (within 2 LSB of Q24 of the exact value without a warp, 4 with one).
#[inline]
pub fn contract_q24(u: [i64; 3], warp: Option<&WarpQ24>) -> [i32; 3] {
    let m = u.iter().map(|v| v.unsigned_abs()).max().unwrap_or(0) as i64;
    if m <= ONE_Q24 {
        return match warp {
            None => u.map(|v| ((v + 1) >> 1) as i32),
            Some(w) => core::array::from_fn(|k| ((w.axis(k, u[k]) + 1) >> 1) as i32),
        };
    }
    // 1 − 1/(2m) in Q24: 2²⁴ − 2²³·2²⁴/m
    let f = ONE_Q24 - (1i64 << 47) / m;
    // u/m in Q24, with u and m shifted right until u·2²⁴ fits an i64
    let shift = (64 - m.leading_zeros()).saturating_sub(38);
    let ms = m >> shift;
    // 1/m in Q24 (below 2²⁴)
    let inv_m = warp.map_or(0, |_| (1i64 << 48) / m);
    core::array::from_fn(|k| {
        let r = ((u[k] >> shift) << 24) / ms;
        let r = match warp {
            None => r,
            Some(w) => r + (((w.axis(k, r) - r) * inv_m + (1 << 23)) >> 24),
        };
        ((r * f + (1 << 23)) >> 24) as i32
    })
}

/// Fixed-point [`s_of_t`]: `t` and `lin` in Q16 (`lin > 0`), `s` in Q30 in
/// `[0, 2³⁰)`, quotients truncated.
#[inline]
pub fn s_of_t_q30(t: i32, lin: i32) -> i32 {
    let (t, lin) = (t.max(0) as i64, lin.max(1) as i64);
    let s = if t < lin { (t << 29) / lin } else { (1 << 30) - (lin << 29) / t };
    s as i32
}

/// Fixed-point [`t_of_s`]: `s` in Q30 (`[0, 2³⁰)`), `lin` in Q16, `t` in
/// Q16 (saturated to i32), quotients truncated. Non-decreasing in `s`.
#[inline]
pub fn t_of_s_q16(s: i32, lin: i32) -> i32 {
    let (s, lin) = (s.max(0) as i64, lin.max(1) as i64);
    let t = if s < HALF_Q30 { (s * lin) >> 29 } else { (lin << 29) / ((1 << 30) - s).max(1) };
    t.min(i32::MAX as i64) as i32
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn contraction_keeps_the_bounds_and_squeezes_the_rest_into_the_shell() {
        assert_eq!(contract_f32(Vec3::new(0.5, -1.0, 0.25), None), Vec3::new(0.25, -0.5, 0.125));
        // distance m along an axis lands at 1 − 1/(2m)
        for m in [1.0f32, 2.0, 10.0, 1e4] {
            let c = contract_f32(Vec3::new(0.0, m, 0.5 * m), None);
            assert!((c.y - (1.0 - 0.5 / m)).abs() < 1e-6 && (c.z - 0.5 * c.y).abs() < 1e-6, "{m}: {c}");
        }
        assert!(contract_f32(Vec3::splat(1e30), None).abs().max_element() <= 1.0);
    }

    /// A focus like the built-in room's: the middle half of x and y, the
    /// bottom of z, each stretched to about twice its width.
    fn room_focus() -> Warp {
        Warp::new(&Focus {
            from: [[-0.25, 0.24], [-0.24, 0.24], [-0.91, -0.44]],
            to: [[-0.49, 0.48], [-0.49, 0.49], [-0.94, 0.0]],
        })
    }

    #[test]
    fn a_focus_stretches_its_part_of_the_bounds_and_fades_beyond_them() {
        let w = room_focus();
        // inside: the focus interval lands on `to`/2, the bounds stay the bounds
        let c = contract_f32(Vec3::new(-0.25, 0.24, -0.44), Some(&w));
        assert!((c - Vec3::new(-0.245, 0.245, 0.0)).abs().max_element() < 1e-6, "{c}");
        assert_eq!(contract_f32(Vec3::new(1.0, -1.0, 1.0), Some(&w)), Vec3::new(0.5, -0.5, 0.5));
        // continuous at the bounds' faces, from any direction
        for k in 0..200 {
            let h = |j: u32| crate::sampling::hash32(k * 7 + j) as f32 / u32::MAX as f32 * 2.0 - 1.0;
            let mut v = Vec3::new(h(1), h(2), h(3));
            v[(k % 3) as usize] = if k % 2 == 0 { 1.0 } else { -1.0 };
            let (inside, outside) =
                (contract_f32(v * (1.0 - 1e-6), Some(&w)), contract_f32(v * (1.0 + 1e-6), Some(&w)));
            assert!((inside - outside).abs().max_element() < 1e-5, "{v}: {inside} {outside}");
            // beyond the bounds distance m still lands at 1 − 1/(2m), and the stretch fades as 1/m
            for m in [1.5f32, 4.0, 1e3] {
                let c = contract_f32(v * m, Some(&w));
                assert!((c.abs().max_element() - (1.0 - 0.5 / m)).abs() < 1e-5, "{v} {m}: {c}");
                let plain = contract_f32(v * m, None);
                let full = (w.apply(v) - v).abs().max_element() * (1.0 - 0.5 / m);
                assert!((c - plain).abs().max_element() <= full / m + 1e-5, "{v} {m}");
            }
        }
        // monotone along each axis: the grid keeps the order of space
        let mut prev = -1.0;
        for i in -1000..=1000 {
            let x = contract_f32(Vec3::new(0.0, 0.0, i as f32 / 100.0), Some(&w)).z;
            assert!(x >= prev, "{i}");
            prev = x;
        }
    }

    #[test]
    fn the_fixed_contraction_follows_the_f32_one_within_its_bound() {
        for warp in [None, Some(room_focus())] {
            let bound = if warp.is_some() { 4 } else { 2 };
            let wq = warp.as_ref().map(WarpQ24::new);
            let mut worst = 0i64;
            for k in 0..20_000u32 {
                let h = |j: u32| crate::sampling::hash32(k.wrapping_mul(2654435761) ^ j);
                // magnitudes from 0.01 to 10⁴ (Q24), any sign
                let scale = 10f32.powf((h(9) % 6000) as f32 / 1000.0 - 2.0);
                let u = [h(1), h(2), h(3)].map(|x| (x as f32 / u32::MAX as f32 * 2.0 - 1.0) * scale);
                let q = u.map(|x| (x as f64 * ONE_Q24 as f64).round() as i64);
                let back = q.map(|x| x as f32 / ONE_Q24 as f32);
                let want = contract_f32(Vec3::from(back), warp.as_ref());
                let got = contract_q24(q, wq.as_ref());
                for c in 0..3 {
                    let err = (got[c] as i64 - (want[c] as f64 * ONE_Q24 as f64).round() as i64).abs();
                    worst = worst.max(err);
                }
            }
            assert!(worst <= bound, "worst {worst} LSB (a focus: {})", warp.is_some());
            // far beyond any scene: still inside the grid
            let far = contract_q24([1 << 61, -(1 << 60), 3], wq.as_ref());
            assert!(far.iter().all(|v| v.abs() <= 1 << 24), "{far:?}");
        }
    }

    #[test]
    fn spacing_is_linear_then_inverse_and_round_trips() {
        let lin = 2.0;
        assert_eq!(s_of_t(1.0, lin), 0.25);
        assert_eq!(t_of_s(0.75, lin), 4.0);
        // within f32's resolution of s: one ulp of s near 1 moves t by t·2⁻²⁴/(1 − s)
        for t in [0.0f32, 0.3, 1.99, 2.0, 2.01, 7.0, 100.0, 3e4] {
            let s = s_of_t(t, lin);
            let tol = (1e-5 + 2f32.powi(-24) / (1.0 - s)) * t.max(1.0);
            assert!((t_of_s(s, lin) - t).abs() <= tol, "{t}: {}", t_of_s(s, lin));
        }
        // fixed point: monotone, and within 1e-3 relative (plus a Q16 step) of the f32 spacing
        let lin_q = 2 << 16;
        let mut prev = 0;
        for s in (0..(1 << 30) - (1 << 14)).step_by(1 << 14) {
            let t = t_of_s_q16(s, lin_q);
            assert!(t >= prev, "{s}");
            prev = t;
            let want = t_of_s(s as f32 / (1u32 << 30) as f32, lin);
            assert!(((t as f32 / 65536.0) - want).abs() <= 1e-3 * want + 2.0 / 65536.0, "{s}: {t} vs {want}");
        }
        for t in [0, 1 << 16, 2 << 16, 9 << 16, 30000 << 16] {
            let s = s_of_t_q30(t, lin_q);
            let back = t_of_s_q16(s, lin_q);
            assert!((back - t).abs() <= 1 + t / 16384, "{t}: {back}");
        }
    }
}
