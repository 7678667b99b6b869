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
//! Spacing (Zip-NeRF's piecewise "linear then inverse"): a sample at `s ∈
//! [0, 1)` sits at `t = 2Ts` for `s < ½` and at `t = T/(2(1 − s))` beyond,
//! `T` being [`crate::format::Unbounded::linear_until`]: samples evenly
//! spaced in `s` are evenly spaced in `t` up to `T` and in `1/t` after it,
//! as the contraction spaces space.

/// Contracted position (in `[−1, 1]³`) of the normalised position `p`.
#[inline]
pub fn contract_f32(p: glam::Vec3) -> glam::Vec3 {
    let m = p.abs().max_element();
    if m <= 1.0 {
        0.5 * p
    } else {
        p * ((1.0 - 0.5 / m) / m)
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

/// Fixed-point [`contract_f32`]: `u` in Q24 (any magnitude an i64 holds up
/// to 2⁶²), the result in Q24 within `[−2²⁴, 2²⁴]`. Inside the bounds the
/// halving rounds half up; beyond them the two quotients truncate toward
/// zero (within 2 LSB of Q24 of the exact value).
#[inline]
pub fn contract_q24(u: [i64; 3]) -> [i32; 3] {
    let m = u.iter().map(|v| v.unsigned_abs()).max().unwrap_or(0) as i64;
    if m <= ONE_Q24 {
        return u.map(|v| ((v + 1) >> 1) as i32);
    }
    // 1 − 1/(2m) in Q24: 2²⁴ − 2²³·2²⁴/m
    let f = ONE_Q24 - (1i64 << 47) / m;
    // u/m in Q24, with u and m shifted right until u·2²⁴ fits an i64
    let shift = (64 - m.leading_zeros()).saturating_sub(38);
    let ms = m >> shift;
    u.map(|v| {
        let r = ((v >> shift) << 24) / ms;
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
        assert_eq!(contract_f32(Vec3::new(0.5, -1.0, 0.25)), Vec3::new(0.25, -0.5, 0.125));
        // distance m along an axis lands at 1 − 1/(2m)
        for m in [1.0f32, 2.0, 10.0, 1e4] {
            let c = contract_f32(Vec3::new(0.0, m, 0.5 * m));
            assert!((c.y - (1.0 - 0.5 / m)).abs() < 1e-6 && (c.z - 0.5 * c.y).abs() < 1e-6, "{m}: {c}");
        }
        assert!(contract_f32(Vec3::splat(1e30)).abs().max_element() <= 1.0);
    }

    #[test]
    fn the_fixed_contraction_follows_the_f32_one_within_two_lsb() {
        let mut worst = 0i64;
        for k in 0..20_000u32 {
            let h = |j: u32| crate::sampling::hash32(k.wrapping_mul(2654435761) ^ j);
            // magnitudes from 0.01 to 10⁴ (Q24), any sign
            let scale = 10f32.powf((h(9) % 6000) as f32 / 1000.0 - 2.0);
            let u = [h(1), h(2), h(3)].map(|x| (x as f32 / u32::MAX as f32 * 2.0 - 1.0) * scale);
            let q = u.map(|x| (x as f64 * ONE_Q24 as f64).round() as i64);
            let back = q.map(|x| x as f32 / ONE_Q24 as f32);
            let want = contract_f32(Vec3::from(back));
            let got = contract_q24(q);
            for c in 0..3 {
                let err = (got[c] as i64 - (want[c] as f64 * ONE_Q24 as f64).round() as i64).abs();
                worst = worst.max(err);
            }
        }
        assert!(worst <= 2, "worst {worst} LSB");
        // far beyond any scene: still inside the grid
        let far = contract_q24([1 << 61, -(1 << 60), 3]);
        assert!(far.iter().all(|v| v.abs() <= 1 << 24), "{far:?}");
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
