//! Positional encoding γ (NeRF eq. 4), f32 and fixed point.
//!
//! Convention (written down because implementations differ): for each
//! coordinate `p` of a *normalised* position (scene bounds mapped to
//! `[−1, 1]³`, see [`crate::camera::Ray`]) or of a unit view direction,
//!
//! `γ(p) = (p, sin(2⁰πp), …, sin(2^{L−1}πp), cos(2^{L−1}πp))` laid out as
//! `[p₀ p₁ p₂ | sin(2⁰πp₀) sin(2⁰πp₁) sin(2⁰πp₂) | cos(2⁰πp₀) … | sin(2¹πp₀) …]`
//! — the paper's π factor, nerf-pytorch's ordering. The raw `p` block is
//! present only with `include_input`.
//!
//! Both paths reduce the phase exactly: `2ᵏ·p` is an exact scaling, and only
//! the fractional number of turns is kept, so large `k` loses nothing beyond
//! the precision of `p` itself.

use crate::arch::sin_turns_q15_slice;
use crate::fixed::{sat_i16, shr_round_i64};
use crate::limits::MAX_FREQS;

pub use crate::fixed::NPOS_FRAC;

/// `sin(π·x)` and `cos(π·x)` for any finite f32 `x` with exact reduction.
///
/// Method: `q = round(2x)` (ties to even) and `f = x − q/2 ∈ [−¼, ¼]` are exact in f32;
/// Taylor polynomials of degree 9 (sin) and 8 (cos) in `πf` (truncation
/// < 3·10⁻⁸), then a rotation by `q` quarter turns. Maximum error
/// ≈ 2·10⁻⁷ (a few f32 ulps); no libm call. Non-finite `x` gives
/// `(0, 1)`, the value at 0 (as [`encode_f32`] treats such coordinates).
#[inline]
pub fn sincospi_f32(x: f32) -> (f32, f32) {
    if !x.is_finite() {
        return (0.0, 1.0);
    }
    let q = round_f32(2.0 * x);
    let f = x - 0.5 * q;
    let a = core::f32::consts::PI * f;
    let a2 = a * a;
    let s = a * (1.0 + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 + a2 * (-1.0 / 5040.0 + a2 * (1.0 / 362880.0)))));
    let c = 1.0 + a2 * (-0.5 + a2 * (1.0 / 24.0 + a2 * (-1.0 / 720.0 + a2 * (1.0 / 40320.0))));
    // q mod 4 via the integer (|q| ≤ 2^25 is exact; beyond, f32 x is even anyway).
    match (q as i64).rem_euclid(4) {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Rounds to the nearest integer, ties to even, branch-light: adding and
/// subtracting 1.5·2²³ leaves an integer for |v| < 2²³; larger f32 values
/// are integers already.
#[inline(always)]
fn round_f32(v: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    if v.abs() < 8_388_608.0 {
        (v + MAGIC) - MAGIC
    } else {
        v
    }
}

/// Encodes `p` (3 coordinates) with `freqs` frequencies into `out`,
/// returning the number of values written (`3·(include_input + 2·freqs)`).
/// Non-finite coordinates encode as 0.
#[inline]
pub fn encode_f32(p: [f32; 3], freqs: usize, include_input: bool, out: &mut [f32]) -> usize {
    let p = p.map(|v| if v.is_finite() { v } else { 0.0 });
    let mut n = 0;
    if include_input {
        out[..3].copy_from_slice(&p);
        n = 3;
    }
    let mut scale = 1.0f32;
    for _ in 0..freqs {
        for c in 0..3 {
            let (s, co) = sincospi_f32(p[c] * scale);
            out[n + c] = s;
            out[n + 3 + c] = co;
        }
        n += 6;
        scale *= 2.0;
    }
    n
}

/// Fixed-point encoding of a Q24 position (or direction) into i16 features.
///
/// Sin/cos features are Q15; the raw block is `p` requantised to
/// `raw_frac_bits` fractional bits and saturated to i16. The phase of
/// frequency `k` is `p·2^{k−1}` turns, computed as a wrapping left shift of
/// the Q24 integer into turns·2³² — exact for every `k` ≤ 16.
#[inline]
pub fn encode_fixed(p: [i32; 3], freqs: usize, include_input: bool, raw_frac_bits: u32, out: &mut [i16]) -> usize {
    let mut n = 0;
    if include_input {
        for c in 0..3 {
            out[c] = sat_i16(shr_round_i64(p[c] as i64, NPOS_FRAC - raw_frac_bits));
        }
        n = 3;
    }
    // phases first, then one table lookup each (a loop the compiler can
    // vectorise); cos is sin a quarter turn later
    let mut phases = [0u32; 6 * MAX_FREQS];
    let freqs = freqs.min(MAX_FREQS);
    for k in 0..freqs {
        // turns·2³² = p·2^(k−1)·2^(32−24) = p << (k + 7)
        for c in 0..3 {
            let phase = (p[c] as u32).wrapping_shl(k as u32 + 32 - 1 - NPOS_FRAC);
            phases[6 * k + c] = phase;
            phases[6 * k + 3 + c] = phase.wrapping_add(1 << 30);
        }
    }
    let m = 6 * freqs;
    sin_turns_q15_slice(&phases[..m], &mut out[n..n + m]);
    n + m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sincospi_matches_f64_reference() {
        for i in -20000..20000 {
            let x = i as f32 * 0.000_731;
            let (s, c) = sincospi_f32(x);
            let a = core::f64::consts::PI * x as f64;
            assert!((s as f64 - libm::sin(a)).abs() < 3e-7, "sin at {x}");
            assert!((c as f64 - libm::cos(a)).abs() < 3e-7, "cos at {x}");
        }
    }

    #[test]
    fn f32_reduction_is_exact_for_large_arguments() {
        // sin(π·(2^15 + 0.25)) = sin(π/4): naive sinf loses this.
        let (s, c) = sincospi_f32(32768.25);
        assert!((s - core::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6);
        assert!((c - core::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6);
    }

    #[test]
    fn fixed_matches_f32_for_all_frequencies() {
        let mut f = [0f32; 99];
        let mut q = [0i16; 99];
        for i in 0..500 {
            let v = (i as f32 * 0.37).sin() * 1.3;
            let p = [v, -v * 0.5, v * 0.25 + 0.1];
            let pq = p.map(|x| libm::roundf(x * (1 << NPOS_FRAC) as f32) as i32);
            // encode the exactly representable value in f32 too
            let pr = pq.map(|x| x as f32 / (1 << NPOS_FRAC) as f32);
            let n = encode_f32(pr, 16, true, &mut f);
            let m = encode_fixed(pq, 16, true, 13, &mut q);
            assert_eq!(n, m);
            for j in 3..n {
                let want = f[j] * 32768.0;
                // one Q15 LSB from the table, plus the f32 sinf error at 2^15π.
                assert!((q[j] as f32 - want).abs() <= 2.0, "feature {j}: {} vs {want}", q[j]);
            }
            for j in 0..3 {
                assert!((q[j] as f32 / 8192.0 - pr[j]).abs() <= 1.0 / 8192.0);
            }
        }
    }
}
