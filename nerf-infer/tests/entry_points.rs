//! The encoding's and the samplers' entry points given NaN, infinities,
//! empty and reversed ranges: finite, in range and sorted outputs.

use nerf_infer::fixed::to_fixed;

#[test]
fn encoding_entry_points_take_nan_and_infinity() {
    use nerf_infer::encoding::{encode_f32, sincospi_f32};
    for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(sincospi_f32(x), (0.0, 1.0));
        let mut out = [7.0f32; 3 * 33];
        let n = encode_f32([x, 0.5, x], 16, true, &mut out);
        assert!(out[..n].iter().all(|v| v.is_finite() && v.abs() <= 1.0), "{x}: {:?}", &out[..n]);
    }
    // the highest frequency at the edges of the coordinate range: sin(2^15 π p)
    // for p = ±1 is exactly 0, cos exactly 1
    let mut out = [0.0f32; 3 * 33];
    encode_f32([1.0, -1.0, 1.0 - f32::EPSILON], 16, true, &mut out);
    assert!(out.iter().all(|v| v.abs() <= 1.0));
    assert_eq!(sincospi_f32(32768.0), (0.0, 1.0));
    assert_eq!(sincospi_f32(-32768.0), (0.0, 1.0));
}

#[test]
fn sampling_entry_points_take_nan_and_infinity() {
    use nerf_infer::sampling::stratified_fixed;
    use nerf_infer::sampling::{sample_pdf_f32, stratified_f32};
    for n in [0, 1, 2, 8] {
        let mut t = vec![0.0f32; n];
        let mut tq = vec![0i32; n];
        for (near, far) in [(f32::NAN, 6.0), (2.0, f32::INFINITY), (2.0, 2.0), (6.0, 2.0), (2.0, 6.0)] {
            for jitter in [None, Some(9)] {
                stratified_f32(near, far, jitter, &mut t);
                let ok = t.iter().all(|v| v.is_finite()) && t.windows(2).all(|p| p[0] <= p[1]);
                assert!(ok, "{n} samples over {near}..{far}, jitter {jitter:?}: {t:?}");
                stratified_fixed(to_fixed(near, 16), to_fixed(far, 16), jitter, &mut tq);
                assert!(tq.windows(2).all(|p| p[0] <= p[1]), "{n} over {near}..{far} (Q16): {tq:?}");
            }
        }
    }
    let tc = [2.0, 2.5, 3.0, 3.5, 4.0];
    let mut cdf = [0.0f32; 5];
    let mut out = [0.0f32; 16];
    for w in [[f32::NAN; 5], [f32::INFINITY; 5], [0.0; 5], [-1.0, 1e30, f32::NAN, 0.0, f32::MAX]] {
        sample_pdf_f32(&tc, &w, |j| j as f32 / 15.0, &mut cdf, &mut out);
        assert!(out.iter().all(|v| (2.0..=4.0).contains(v)), "weights {w:?}: {out:?}");
        assert!(out.windows(2).all(|p| p[0] <= p[1]), "weights {w:?}: not sorted: {out:?}");
    }
}
