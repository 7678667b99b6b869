//! Property tests: the fixed-point encoding against the f32 encoding over
//! random coordinates (exactly representable in Q24, so both paths see the
//! same input) and every frequency up to 16.

use nerf_infer::encoding::{encode_f32, encode_fixed, NPOS_FRAC};
use proptest::prelude::*;

/// Tolerance in Q15 units: 1 LSB from the table interpolation, 1 from the
/// f32 polynomial and rounding.
const TOL_Q15: f32 = 2.0;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn fixed_encoding_matches_f32(q in prop::array::uniform3(prop_oneof![-(1i32 << NPOS_FRAC)..(1i32 << NPOS_FRAC), -(100i32 << NPOS_FRAC)..(100i32 << NPOS_FRAC)]), freqs in 0usize..=16, raw_bits in 0u32..=8) {
        let p = q.map(|v| v as f64 / (1u64 << NPOS_FRAC) as f64);
        let mut f = [0f32; 99];
        let mut x = [0i16; 99];
        let pf = p.map(|v| v as f32);
        let n = encode_f32(pf, freqs, true, &mut f);
        let m = encode_fixed(q, freqs, true, raw_bits, &mut x);
        prop_assert_eq!(n, m);
        for k in 0..freqs {
            for c in 0..3 {
                // exact value of the fixed path's input
                let turns = (p[c] * (1u64 << k) as f64 / 2.0).rem_euclid(1.0);
                let ang = turns * std::f64::consts::TAU;
                let (s, co) = (ang.sin() * 32768.0, ang.cos() * 32768.0);
                let (xs, xc) = (x[3 + 6 * k + c] as f64, x[3 + 6 * k + 3 + c] as f64);
                prop_assert!((xs - s.clamp(-32767.0, 32767.0)).abs() <= TOL_Q15 as f64, "sin k={} c={}: {} vs {}", k, c, xs, s);
                prop_assert!((xc - co.clamp(-32767.0, 32767.0)).abs() <= TOL_Q15 as f64, "cos k={} c={}: {} vs {}", k, c, xc, co);
            }
        }
        // the f32 path agrees where its input is exact: |p| < 1 has at most
        // 24 significant bits, so the Q24 value converts to f32 exactly
        let exact = p.iter().all(|v| v.abs() < 1.0);
        for k in 0..if exact { freqs } else { 0 } {
            for c in 0..3 {
                let want = f[3 + 6 * k + c] * 32768.0;
                prop_assert!((x[3 + 6 * k + c] as f32 - want).abs() <= TOL_Q15 + 2.0);
            }
        }
        for c in 0..3 {
            let raw = (p[c] * (1u64 << raw_bits) as f64).round().clamp(-32768.0, 32767.0);
            prop_assert!((x[c] as f64 - raw).abs() <= 1.0);
        }
    }
}
