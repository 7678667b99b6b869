//! Fixed-point formats and the integer primitives of the fixed-point path.
//!
//! All formats are two's-complement integers with an implied binary point:
//! `Qf` means value = integer · 2⁻ᶠ (resolution Δ = 2⁻ᶠ).
//!
//! | quantity                         | type | format | range                  |
//! |----------------------------------|------|--------|------------------------|
//! | ray origins, `t`, `δ`            | i32  | Q16    | ±32768 world units     |
//! | ray directions                   | i32  | Q16    | ±32768                 |
//! | normalised positions, view dirs  | i32  | Q24    | ±128 (scene box ±1)    |
//! | encoding sin/cos                 | i16  | Q15    | [−1, 1] (saturated)    |
//! | hidden activations               | i16  | per layer scale, set at export |
//! | density head output σ            | i32  | Q10    | [0, 2²¹) after ReLU    |
//! | colour head output (logit)       | i32  | Q12    | ±2¹⁹                   |
//! | colour, opacity                  | u16  | Q15    | [0, 32768]             |
//! | transmittance, alpha, weights    | u32  | Q30    | [0, 2³⁰]               |
//! | phase                            | u32  | turns · 2³² (wraps exactly) |
//!
//! Rounding: every right shift that drops bits rounds half up (adds 2ⁿ⁻¹
//! before an arithmetic shift); conversions saturate to the target type.

/// Fractional bits of positions, origins, directions and ray parameters `t`.
pub const POS_FRAC: u32 = 16;
/// Fractional bits of normalised positions in the fixed path (Q24 in i32,
/// range ±128 normalised units).
pub const NPOS_FRAC: u32 = 24;
/// Fractional bits of the sin/cos encoding features (Q15).
pub const ENC_FRAC: u32 = 15;
/// Fractional bits of the density head output σ (Q10, in 1/world units).
pub const SIGMA_FRAC: u32 = 10;
/// Fractional bits of the colour head output before the sigmoid (Q12).
pub const LOGIT_FRAC: u32 = 12;
/// Fractional bits of colours and opacity in [`crate::PixelFixed`] (Q15).
pub const COLOR_FRAC: u32 = 15;
/// Fractional bits of transmittance, alpha and compositing weights (Q30).
pub const T_FRAC: u32 = 30;
/// 1.0 in Q30.
pub const T_ONE: u32 = 1 << T_FRAC;
/// 1.0 in Q15 colour units.
pub const COLOR_ONE: u16 = 1 << COLOR_FRAC;

/// Converts an `f32` to a fixed-point i32 with `frac` fractional bits,
/// rounding to nearest and saturating; NaN maps to 0.
pub fn to_fixed(x: f32, frac: u32) -> i32 {
    if x.is_nan() {
        return 0;
    }
    let v = x * (1u64 << frac) as f32;
    if v >= i32::MAX as f32 {
        i32::MAX
    } else if v <= i32::MIN as f32 {
        i32::MIN
    } else {
        round_half_away(v)
    }
}

/// `v` rounded to the nearest integer, halves away from zero (as
/// `libm::roundf`), for `|v| < 2³¹`: the integer part and the fraction are
/// exact in f32 (an f32 of magnitude ≥ 2²³ is an integer already).
#[inline(always)]
fn round_half_away(v: f32) -> i32 {
    let whole = v as i32; // toward zero
    let frac = v - whole as f32;
    whole + (frac >= 0.5) as i32 - (frac <= -0.5) as i32
}

/// Arithmetic right shift by `n` (0..=63) rounding half up.
#[inline(always)]
pub fn shr_round_i64(x: i64, n: u32) -> i64 {
    if n == 0 {
        x
    } else {
        x.saturating_add(1 << (n - 1)) >> n
    }
}

/// Arithmetic right shift of an `i128` by `n` (0..=126) rounding half up.
#[inline(always)]
pub fn shr_round_i128(x: i128, n: u32) -> i128 {
    if n == 0 {
        x
    } else {
        x.saturating_add(1 << (n - 1)) >> n
    }
}

/// Saturates an `i64` to the `i16` range.
#[inline(always)]
pub fn sat_i16(x: i64) -> i16 {
    x.clamp(i16::MIN as i64, i16::MAX as i64) as i16
}

/// Saturates an `i64` to the `i32` range.
#[inline(always)]
pub fn sat_i32(x: i64) -> i32 {
    x.clamp(i32::MIN as i64, i32::MAX as i64) as i32
}

/// Requantisation of an accumulator by a real factor `m · 2⁻⁽³¹⁺ˢʰⁱᶠᵗ⁾`.
///
/// `multiplier` is a Q0.31 mantissa in `[2³⁰, 2³¹)` (or 0 for a zero factor)
/// and `shift` is in `[-31, 31]`, so the total right shift `31 + shift` is in
/// `[0, 62]`. The product is exact (128-bit) and rounded half up, then
/// saturated by the caller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Requant {
    /// Q0.31 mantissa, 0 or in `[2³⁰, 2³¹)`.
    pub multiplier: i32,
    /// Exponent adjustment in `[-31, 31]`; positive values divide further.
    pub shift: i32,
}

impl Requant {
    /// Smallest allowed shift.
    pub const MIN_SHIFT: i32 = -31;
    /// Largest allowed shift.
    pub const MAX_SHIFT: i32 = 31;

    /// Decomposes a real factor (finite, ≥ 0) into multiplier and shift.
    /// Returns `None` when the factor is out of the representable range
    /// `[2⁻³², 2³¹)` (zero is representable exactly).
    pub fn from_f64(factor: f64) -> Option<Self> {
        if !factor.is_finite() || factor < 0.0 {
            return None;
        }
        if factor == 0.0 {
            return Some(Self { multiplier: 0, shift: 0 });
        }
        // factor = mant · 2^exp with mant in [0.5, 1).
        let mut exp = libm::ilogb(factor) + 1;
        let mant = factor / libm::ldexp(1.0, exp);
        let mut m = libm::round(mant * 2147483648.0) as i64;
        if m == 1 << 31 {
            // mant rounded up to 1.0: renormalise to 0.5 · 2^(exp+1)
            m >>= 1;
            exp += 1;
        }
        let shift = -exp;
        if !(Self::MIN_SHIFT..=Self::MAX_SHIFT).contains(&shift) {
            return None;
        }
        Some(Self { multiplier: m as i32, shift })
    }

    /// True if the constants are in their documented ranges.
    pub fn is_valid(&self) -> bool {
        (self.multiplier == 0 || self.multiplier >= 1 << 30)
            && (Self::MIN_SHIFT..=Self::MAX_SHIFT).contains(&self.shift)
    }

    /// Applies the factor to a 64-bit accumulator, rounding half up, with
    /// the result saturated to `i64`. An accumulator that fits `i32` (every
    /// int8 layer's) takes an exact 64-bit path, bit-identical to the
    /// 128-bit one: `|acc · m| < 2⁶²`, so the rounding bias still fits.
    #[inline(always)]
    pub fn apply(&self, acc: i64) -> i64 {
        if acc == acc as i32 as i64 {
            // n ≤ 62: the bias is at most 2⁶¹ and the sum stays below 2⁶³
            let n = (31 + self.shift) as u32 & 63;
            return (acc * self.multiplier as i64 + ((1i64 << n) >> 1)) >> n;
        }
        let p = acc as i128 * self.multiplier as i128;
        let r = shr_round_i128(p, (31 + self.shift) as u32);
        r.clamp(i64::MIN as i128, i64::MAX as i128) as i64
    }
}

/// Quarter-wave sine table: `SIN_TABLE[i] = sin(i/256 · π/2)` in Q30, i = 0..=256.
pub(crate) static SIN_TABLE: [i32; 257] = build_sin_table();

const fn build_sin_table() -> [i32; 257] {
    let mut t = [0i32; 257];
    let mut i = 0;
    while i <= 256 {
        let x = (i as f64) * core::f64::consts::FRAC_PI_2 / 256.0;
        // Taylor series to x^25: error < 1e-17 on [0, π/2].
        let mut term = x;
        let mut sum = x;
        let mut k = 1;
        while k < 13 {
            term = -term * x * x / (((2 * k) * (2 * k + 1)) as f64);
            sum += term;
            k += 1;
        }
        let v = sum * 1073741824.0;
        t[i] = (v + 0.5) as i32;
        i += 1;
    }
    t
}

/// Sine of a phase given in turns · 2³² (`phase = 2³²` is one full turn),
/// returned in Q15 (saturated to `[-32767, 32767]`).
///
/// Method: quarter-wave symmetry, a 257-entry Q30 table and linear
/// interpolation on the low 22 bits. Maximum error ≈ 4.7·10⁻⁶ before the
/// final rounding to Q15, i.e. at most 1 LSB of Q15.
#[inline]
pub fn sin_turns_q15(phase: u32) -> i16 {
    let quadrant = phase >> 30;
    let within = phase & 0x3FFF_FFFF; // 30 bits within the quadrant
                                      // Mirror for quadrants 1 and 3: sin(π/2 + a) = sin(π/2 − a).
    let pos = if quadrant & 1 == 1 { (1u32 << 30) - within } else { within };
    let idx = (pos >> 22) as usize; // 0..=256
    let frac = (pos & 0x3F_FFFF) as i64; // 22 bits
    let a = SIN_TABLE[idx] as i64;
    let b = SIN_TABLE[if idx < 256 { idx + 1 } else { 256 }] as i64;
    let v = a + (((b - a) * frac) >> 22); // Q30
    let q = shr_round_i64(v, 15).min(32767);
    if quadrant >= 2 {
        -(q as i16)
    } else {
        q as i16
    }
}

/// `exp(−x)` for `x ≥ 0` in Q26, returned in Q30 (`2³⁰` = 1).
///
/// Method: `exp(−x) = 2^(−y)` with `y = x·log₂e` in Q32, split into integer
/// part `n` and fraction `f`; `2^(−f)` is a degree-9 alternating series in
/// Q30 (error < 10⁻⁸), then shifted right by `n`. Negative inputs are
/// treated as 0 (result 1.0); results below 2⁻³⁰ are 0.
#[inline]
pub fn exp_neg_q26_q30(x: i64) -> u32 {
    if x <= 0 {
        return T_ONE;
    }
    // log2(e) in Q30.
    const LOG2E_Q30: i64 = 1_549_082_005;
    // x ≤ 2^32 (64 units, far past underflow) keeps the product below 2^63.
    let x = x.min(1 << 32);
    let y = (x * LOG2E_Q30) >> 24; // Q32
    let n = y >> 32;
    if n >= 31 {
        return 0;
    }
    let f = (y & 0xFFFF_FFFF) >> 2; // fraction in Q30
    let p = exp2_neg_frac_q30(f);
    shr_round_i64(p, n as u32) as u32
}

/// `exp(−x)` for `x ≥ 0` in Q16, returned in Q30: [`exp_neg_q26_q30`] of
/// the same value.
#[inline]
pub fn exp_neg_q16_q30(x: i64) -> u32 {
    exp_neg_q26_q30(x.clamp(0, 1 << 32) << 10)
}

/// `2^(−f)` for `f` in `[0, 1)` given in Q30, result in Q30.
#[inline]
fn exp2_neg_frac_q30(f: i64) -> i64 {
    // 2^(-f) = exp(-f ln2); Taylor in u = f·ln2 ∈ [0, 0.694), to u^7
    // (truncation < 0.694^8/40320 ≈ 1.3·10⁻⁶ relative... refined below).
    // Horner with alternating signs in Q30.
    const LN2_Q30: i64 = 744_261_118;
    let u = (f * LN2_Q30) >> 30;
    // coefficients 1/k! in Q30 for k = 0..=9 (error < 0.694^10/10! < 7e-9).
    const C: [i64; 10] = [
        1_073_741_824,
        1_073_741_824,
        536_870_912,
        178_956_971,
        44_739_243,
        8_947_849,
        1_491_308,
        213_044,
        26_631,
        2_959,
    ];
    let mut acc = C[9];
    let mut k = 9;
    while k > 0 {
        k -= 1;
        // acc = C[k] − u·acc  (alternating series for exp(−u))
        acc = C[k] - ((u * acc) >> 30);
    }
    acc
}

/// Logistic sigmoid of a Q12 logit, returned in Q15 `[0, 32768]`.
///
/// Computed as `1/(1+e^{−|z|})` with [`exp_neg_q16_q30`] and one integer
/// division, mirrored for negative `z`. Error ≤ 1 LSB of Q15.
#[inline]
pub fn sigmoid_q12_q15(z: i32) -> u16 {
    let a = (z as i64).unsigned_abs() as i64;
    let e = exp_neg_q16_q30(a << (16 - LOGIT_FRAC)) as u64; // Q30
                                                            // s = 2^45 / (2^30 + e), in Q15, for the non-negative half.
    let den = (1u64 << 30) + e;
    let s = ((1u64 << 45) + den / 2) / den; // in [16384, 32768]
    if z >= 0 {
        s as u16
    } else {
        (32768 - s) as u16
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requant_i32_fast_path_equals_the_exact_128_bit_product() {
        let mut h = 0x1234_5678u32;
        let mut next = || {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            h
        };
        for k in 0..20000 {
            let r = Requant { multiplier: (1 << 30) | (next() >> 2) as i32, shift: (next() % 63) as i32 - 31 };
            let acc = match k % 4 {
                0 => i32::MAX as i64,
                1 => i32::MIN as i64,
                _ => next() as i32 as i64,
            };
            let exact = shr_round_i128(acc as i128 * r.multiplier as i128, (31 + r.shift) as u32);
            assert_eq!(r.apply(acc) as i128, exact, "{r:?} {acc}");
        }
    }

    #[test]
    fn sine_table_matches_libm_within_one_lsb() {
        for i in 0..4096u32 {
            let phase = i.wrapping_mul(1_048_573).wrapping_mul(997);
            let x = phase as f64 / 4294967296.0 * core::f64::consts::TAU;
            let want = libm::sin(x) * 32768.0;
            let got = sin_turns_q15(phase) as f64;
            assert!((got - want.clamp(-32767.0, 32767.0)).abs() <= 1.0, "phase {phase}: {got} vs {want}");
            // the encoding's cosine is the sine a quarter turn on
            let wantc = (libm::cos(x) * 32768.0).clamp(-32767.0, 32767.0);
            assert!((sin_turns_q15(phase.wrapping_add(1 << 30)) as f64 - wantc).abs() <= 1.0);
        }
    }

    #[test]
    fn exp_neg_matches_libm() {
        for i in 0..20000i64 {
            let x = i * 97; // up to ~30 in Q16
            let want = libm::exp(-(x as f64) / 65536.0) * 1073741824.0;
            let got = exp_neg_q16_q30(x) as f64;
            assert!((got - want).abs() <= 2.0 + want * 2e-7, "x={x}: {got} vs {want}");
        }
        assert_eq!(exp_neg_q16_q30(0), T_ONE);
        assert_eq!(exp_neg_q16_q30(-5), T_ONE);
        assert_eq!(exp_neg_q16_q30(i64::MAX), 0);
    }

    #[test]
    fn exp_neg_q26_is_accurate_for_tiny_arguments() {
        for x in [1i64, 7, 100, 65_535, 1 << 20, 3 << 26] {
            let want = libm::exp(-(x as f64) / 67108864.0) * 1073741824.0;
            let got = exp_neg_q26_q30(x) as f64;
            assert!((got - want).abs() <= 2.0 + want * 2e-7, "x={x}: {got} vs {want}");
        }
    }

    #[test]
    fn rounding_halves_away_from_zero_as_libm_does() {
        let mut h = 0x9E37_79B9u32;
        let check = |v: f32| {
            // to_fixed hands over every f32 below 2^31 in magnitude
            if v.abs() < 2147483648.0 {
                assert_eq!(round_half_away(v), libm::roundf(v) as i32, "{v}");
            }
        };
        for v in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            0.49999997,
            -0.49999997,
            8388607.5,
            -8388607.5,
            8388609.0,
            2147483520.0,
            -2147483520.0,
        ] {
            check(v);
        }
        for _ in 0..200_000 {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            // any f32 below 2^31 in magnitude, and quarters around zero
            check(f32::from_bits(h));
            check(f32::from_bits(h & 0xC7FF_FFFF)); // magnitudes below 2^17
            check((h % 2_000_000) as f32 * 0.25 - 250_000.0);
        }
    }

    #[test]
    fn sigmoid_matches_libm_within_one_lsb() {
        for z in (-70000..70000).step_by(7) {
            let want = 32768.0 / (1.0 + libm::exp(-(z as f64) / 4096.0));
            let got = sigmoid_q12_q15(z) as f64;
            assert!((got - want).abs() <= 1.0, "z={z}: {got} vs {want}");
        }
        assert_eq!(sigmoid_q12_q15(i32::MIN), 0);
        assert_eq!(sigmoid_q12_q15(i32::MAX), 32768);
    }

    #[test]
    fn requant_roundtrips_factor() {
        for &f in &[1.0, 0.5, 3.7e-5, 1234.5, 1e-9, 0.999_999_9] {
            let r = Requant::from_f64(f).unwrap();
            assert!(r.is_valid());
            // the real factor the constants apply
            let factor = r.multiplier as f64 * libm::ldexp(1.0, -(31 + r.shift));
            assert!((factor - f).abs() <= f * 1e-9, "{f} vs {factor}");
        }
        assert_eq!(Requant::from_f64(1e20), None);
        assert_eq!(Requant::from_f64(1e-12), None);
        assert_eq!(Requant::from_f64(f64::NAN), None);
        let r = Requant::from_f64(0.25).unwrap();
        assert_eq!(r.apply(6), 2); // 1.5 rounds half up
        assert_eq!(r.apply(-6), -1); // -1.5 rounds half up
    }
}
