//! Writing model files: the f32 model of a training run, and its int16 /
//! int8 quantisation for the kernel's fixed-point path.
//!
//! Quantisation of a layer `y = W·x + b` whose integer inputs `x_q[j]`
//! stand for `x_q[j]·s_j` (encoding features: `2⁻¹⁵`, raw coordinates:
//! `2^−raw_frac_bits`, hidden activations: `act_max/32767` measured on
//! training rays): the input scales are folded into the weights,
//! `W'[j][c] = W[j][c]·s_j`; each output channel gets its own scale
//! `S[c] = max(maxⱼ|W'[j][c]|/qmax, |b[c]|/2²⁹)`; weights round to
//! `q = round(W'/S)` (ties away from zero) within `±qmax` (32767 or 127)
//! and the bias to `round(b/S)` in i32. The accumulator then holds
//! `y/S[c]`, and the requantisation factor `S[c]/s_out` (or `S[c]·2¹⁰` for
//! the density head, `S[c]·2¹²` for the colour head) becomes a Q0.31
//! multiplier and a shift. The `2²⁹` bias bound keeps int8 layers with up
//! to 355 inputs inside i32: `355·127·2¹⁵ + 2²⁹ < 2³¹`.
//!
//! Three parts of an int8 network are also written at 16 bits: the view
//! layer's direction rows, `round(W'/S · 2⁸)`, summed once per ray, so
//! the 256× finer step costs nothing per sample (their weights are small
//! beside the feature rows', which set `S`, and 8 bits left them a few
//! steps each); the colour head, quantised as in an int16 model (3
//! outputs, evaluated only for samples with weight; both format version
//! 6); and the density head, quantised as in an int16 model (one output;
//! format version 8: 8-bit density weights cost the most PSNR of any
//! layer, docs/EXPERIMENTS.md).

use crate::error::{Error, ExportError};
use crate::mlp::Mlp;
use crate::train::Trainer;
use nerf_infer::features::FeatureGrid;
use nerf_infer::fixed::{Requant, ENC_FRAC, LOGIT_FRAC, SIGMA_FRAC};
use nerf_infer::format::{
    self, read_f32, read_i16, sigma_layer, Encoding, Layer, Meta, Model, Network, Scene, Scheme, Topology,
};
use nerf_infer::network::OUTPUT_TILE;

mod float;
mod prune;
mod quantise;
mod table;
pub use float::*;
pub use nerf_infer::format::owned::{OwnedLayer, OwnedModel, OwnedNetwork, OwnedPrecise};
pub use prune::*;
pub use quantise::*;
pub use table::*;

#[cfg(test)]
mod tests {
    use super::{lloyd_max, value_weights};
    use nerf_infer::features::{geometric_resolutions, FeatureGrid};

    fn sse(values: &[i16], codes: &[i16]) -> i64 {
        values.iter().map(|&v| codes.iter().map(|&c| (c as i64 - v as i64).pow(2)).min().unwrap()).sum()
    }

    fn weighted_sse(values: &[i16], weights: &[f64], codes: &[i16]) -> f64 {
        let err = |v: i16| codes.iter().map(|&c| (c as f64 - v as f64).powi(2)).fold(f64::MAX, f64::min);
        values.iter().zip(weights).map(|(&v, &w)| w * err(v)).sum()
    }

    /// Values that count little (weight 10⁻⁴) spread wide around a bunch
    /// that counts: the weighted codes have less weighted error than codes
    /// fitted without the weights, and more of them sit in the bunch.
    #[test]
    fn weights_pull_the_codes_to_the_values_that_count() {
        let values: Vec<i16> = (0..4000i32)
            .map(|i| if i % 2 == 0 { (i * 37 % 401 - 200) as i16 } else { (i * 7919 % 60_001 - 30_000) as i16 })
            .collect();
        let weights: Vec<f64> = (0..4000).map(|i| if i % 2 == 0 { 1.0 } else { 1e-4 }).collect();
        let even = vec![1.0; values.len()];
        let (weighted, plain) = (lloyd_max(&values, &weights, 16), lloyd_max(&values, &even, 16));
        let (a, b) = (weighted_sse(&values, &weights, &weighted), weighted_sse(&values, &weights, &plain));
        println!("weighted error {a:.0} with weighted codes, {b:.0} with plain ones");
        assert!(a < b, "{a} against {b}");
        let in_bunch = |codes: &[i16]| codes.iter().filter(|c| c.abs() <= 200).count();
        println!("codes in the bunch: {} weighted, {} plain", in_bunch(&weighted), in_bunch(&plain));
        assert!(in_bunch(&weighted) > in_bunch(&plain), "{weighted:?} against {plain:?}");
    }

    /// With one occupied cell of a 2³ occupancy grid, the vertices of that
    /// octant (a dense level) take weight; the rest keep only the floor.
    #[test]
    fn value_weights_follow_the_occupied_cells() {
        let shape = FeatureGrid {
            width: 1,
            log2_table: 10,
            frac_bits: 0,
            resolutions: geometric_resolutions(1, 4, 4),
            table: &[],
            narrow: None,
        };
        let grid = (2u16, vec![0b0000_0001u8]); // cell (0, 0, 0): x, y, z < 0
        let w = value_weights(&shape, Some(&grid));
        assert_eq!(w.len(), 125);
        let floor = w.iter().cloned().fold(f64::MAX, f64::min);
        for (e, &v) in w.iter().enumerate() {
            let vertex = [e % 5, e / 5 % 5, e / 25];
            // the octant's cells span vertices 0..=2 per axis
            let inside = vertex.iter().all(|&i| i <= 2);
            assert_eq!(v > floor * 10.0, inside, "vertex {vertex:?}: weight {v} (floor {floor})");
        }
        // without a grid every vertex is read
        let all = value_weights(&shape, None);
        let least = all.iter().cloned().fold(f64::MAX, f64::min);
        assert!(least > 1e-3 * all.iter().sum::<f64>() / 125.0 * 10.0, "{least}");
    }

    /// On values bunched near zero with a long tail (as a trained table's
    /// are), the codebook has less than half the squared error of the even one over
    /// the same range it starts from, keeps the extremes within reach, and
    /// comes out sorted and distinct.
    #[test]
    fn lloyd_max_codes_beat_even_codes_on_a_peaked_distribution() {
        // a Laplace spread of scale 200 (half the values within ±139), tails to ±1 842
        let values: Vec<i16> = (1..20_000i64)
            .map(|i| {
                let u = (i * 7919 % 20_000) as f64 / 20_000.0 - 0.5;
                (-u.signum() * 200.0 * (1.0 - 2.0 * u.abs()).max(1e-7).ln()).clamp(-30_000.0, 30_000.0) as i16
            })
            .collect();
        let (lo, hi) = (*values.iter().min().unwrap() as f64, *values.iter().max().unwrap() as f64);
        for k in [16usize, 256] {
            let codes = lloyd_max(&values, &vec![1.0; values.len()], k);
            assert_eq!(codes.len(), k);
            assert!(codes.windows(2).all(|c| c[0] < c[1]), "{k} codes not sorted and distinct: {codes:?}");
            let even: Vec<i16> =
                (0..k).map(|i| (lo + (hi - lo) * (i as f64 + 0.5) / k as f64).round() as i16).collect();
            let (got, start) = (sse(&values, &codes), sse(&values, &even));
            println!("{k} codes: squared error {got} against {start} with even codes");
            assert!(got * 2 < start, "{k} codes: {got} against {start}");
        }
    }

    /// Fewer distinct values than codes: each value is a code, exactly.
    #[test]
    fn lloyd_max_codes_every_value_of_a_small_set() {
        let values = [-7i16, 3, 3, 3, 100, -7, 12];
        let codes = lloyd_max(&values, &[1.0; 7], 16);
        assert_eq!(sse(&values, &codes), 0, "{codes:?}");
        assert_eq!(lloyd_max(&[], &[], 4), [0; 4]);
    }
}
