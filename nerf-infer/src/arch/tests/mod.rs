//! Every kernel of this build against its portable reference, bit for bit:
//! the kernel the crate picks (`selected_*`) and each architecture's own
//! (`avx2_*`, `vnni_*`, where the build carries them; a kernel the CPU
//! cannot run is reported and skipped), on the same cases. One macro, one
//! list: a new architecture adds its lines here.

extern crate std;
use std::vec::Vec;

use super::*;
use crate::features::{geometric_resolutions, NarrowTable};
use crate::fixed::{Requant, NPOS_FRAC};
use crate::layer::{accumulate, requant_rows, Input, MacF32};

mod lookups;
use lookups::*;

/// `$test`: for every case of `$cases`, `$kernel(&case)` equals
/// `$reference(&case)`.
/// `$token` is the kernel set's proof that the CPU has it (`Some(())`
/// for kernels every CPU of the target runs).
macro_rules! same_as_reference {
    ($($(#[$cfg:meta])* $test:ident($token:expr): $cases:expr, $kernel:expr, $reference:expr;)*) => {$(
        $(#[$cfg])*
        #[test]
        fn $test() {
            let Some(k) = $token else {
                std::eprintln!("{}: this CPU cannot run the kernel; skipped", stringify!($test));
                return;
            };
            let kernel = |c| $kernel(k, c);
            let cases = $cases;
            assert!(!cases.is_empty());
            for (k, case) in cases.iter().enumerate() {
                assert!(kernel(case) == $reference(case), "case {k}");
            }
        }
    )*};
}

/// xorshift32, for reproducible cases.
fn rng(seed: u32) -> impl FnMut() -> u32 {
    let mut h = seed;
    move || {
        h ^= h << 13;
        h ^= h >> 17;
        h ^= h << 5;
        h
    }
}

// ---- sine of phases

/// Quadrant and table-entry edges, then a sweep with all low bits busy, in
/// lengths around the 8-lane groups.
fn sine_cases() -> Vec<Vec<u32>> {
    let mut phases = Vec::new();
    for q in 0..4u32 {
        for e in [0u32, 1, (1 << 22) - 1, 1 << 22, (1 << 30) - (1 << 22), (1 << 30) - 1] {
            phases.push((q << 30).wrapping_add(e));
        }
    }
    phases.push(u32::MAX);
    phases.extend((0..200_003u32).map(|i| i.wrapping_mul(2_654_435_761) ^ (i << 7)));
    [phases.len(), 7, 8, 9, 0].iter().map(|&n| phases[..n].to_vec()).collect()
}

fn sine_reference(phases: &[u32]) -> Vec<i16> {
    phases.iter().map(|&p| sin_turns_q15(p)).collect()
}

fn sine_selected(_: (), phases: &[u32]) -> Vec<i16> {
    let mut out = std::vec![0; phases.len()];
    sin_turns_q15_slice(phases, &mut out);
    out
}

#[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
fn sine_avx2(k: avx2::Avx2, phases: &[u32]) -> Vec<i16> {
    let mut out = std::vec![0; phases.len()];
    let done = avx2::sin_turns_q15_x8(k, phases, &mut out);
    assert_eq!(done, phases.len() / 8 * 8);
    (out[..done].iter().copied()).chain(phases[done..].iter().map(|&p| sin_turns_q15(p))).collect()
}

// ---- the int8 dense layer

/// A layer's weights, its inputs and the rows it reads.
struct LayerCase {
    weights: Vec<u8>,
    od: usize,
    row0: usize,
    in_dim: usize,
    n: usize,
    input: [[i16; MAX_WIDTH]; 8],
}

/// The shapes the format allows: odd and even inputs, narrow and wide
/// outputs, short tiles; half the inputs zero (ReLU).
fn layer_cases() -> Vec<LayerCase> {
    let mut next = rng(0x9e37_79b9);
    let mut cases = Vec::new();
    for in_dim in [1usize, 2, 51, 64, 79, 255, 256] {
        for od in [1usize, 3, 7, 32, 40, 45, 48, 64, 255, 256] {
            for n in [1usize, 3, 5, 8] {
                let row0 = (next() % 3) as usize;
                let weights = (0..(row0 + in_dim) * od).map(|_| next() as u8).collect();
                let mut input = [[0i16; MAX_WIDTH]; 8];
                for x in input.iter_mut().flatten() {
                    *x = if next().is_multiple_of(2) { 0 } else { (next() % 4096) as i16 - 2048 };
                }
                cases.push(LayerCase { weights, od, row0, in_dim, n, input });
            }
        }
    }
    cases
}

/// Runs `kernel` on the case's layer and input, into a fresh accumulator
/// (every row starting at a marker).
fn layer_with(
    c: &LayerCase,
    kernel: impl Fn(&Layer<'_>, Input<'_, i16, MAX_WIDTH>, &mut [[i32; MAX_WIDTH]]),
) -> Vec<[i32; MAX_WIDTH]> {
    let l = Layer {
        in_dim: (c.row0 + c.in_dim) as u16,
        out_dim: c.od as u16,
        act_max: 0.0,
        weights: &c.weights,
        bias: &[],
        scales: &[],
        requant: &[],
    };
    let x = Input { rows: &c.input, row0: c.row0, width: c.in_dim, n: c.n };
    let mut acc = std::vec![[0x1234_5678 >> 8; MAX_WIDTH]; 8];
    kernel(&l, x, &mut acc);
    acc
}

fn layer_reference(c: &LayerCase) -> Vec<[i32; MAX_WIDTH]> {
    layer_with(c, |l, x, acc| accumulate::<W8, MAX_WIDTH>(l, 0, x, acc))
}

fn layer_selected(_: (), c: &LayerCase) -> Vec<[i32; MAX_WIDTH]> {
    layer_with(c, W8::accumulate_wide)
}

#[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
fn layer_avx2(k: avx2::Avx2, c: &LayerCase) -> Vec<[i32; MAX_WIDTH]> {
    layer_with(c, |l, x, acc| avx2::accumulate_i8(k, l, x, acc))
}

/// VNNI takes the whole 32-wide tiles; the portable loop the rest.
#[cfg(all(
    target_arch = "x86_64",
    any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
))]
fn layer_vnni(k: vnni::Vnni, c: &LayerCase) -> Vec<[i32; MAX_WIDTH]> {
    layer_with(c, |l, x, acc| {
        vnni::accumulate_i8(k, l, x, acc);
        accumulate::<W8, MAX_WIDTH>(l, c.od - c.od % crate::layer::TILE_C, x, acc)
    })
}

// ---- the f32 dense layer

/// The int8 cases' shapes with f32 weights and inputs (half the inputs
/// zero), as bit patterns so that equality is exact.
fn f32_layer_cases() -> Vec<F32Case> {
    let mut next = rng(0x85eb_ca6b);
    let mut f = move || (next() % 20001) as f32 / 1e4 - 1.0;
    let mut cases = Vec::new();
    for in_dim in [1usize, 2, 51, 64, 79, 256] {
        for od in [1usize, 3, 7, 32, 45, 64, 256] {
            for n in [1usize, 3, 8] {
                let row0 = 1;
                let weights = (0..(row0 + in_dim) * od).flat_map(|_| f().to_le_bytes()).collect();
                let mut input = [[0f32; MAX_WIDTH]; 8];
                for x in input.iter_mut().flatten() {
                    let v = f();
                    *x = if v < 0.0 { 0.0 } else { v * 3.0 };
                }
                cases.push((weights, od, row0, in_dim, n, input));
            }
        }
    }
    cases
}

type F32Case = (Vec<u8>, usize, usize, usize, usize, [[f32; MAX_WIDTH]; 8]);

fn f32_layer_with(
    c: &F32Case,
    kernel: impl Fn(&Layer<'_>, Input<'_, f32, MAX_WIDTH>, &mut [[f32; MAX_WIDTH]]),
) -> Vec<[u32; MAX_WIDTH]> {
    let (weights, od, row0, in_dim, n, input) = c;
    let l = Layer {
        in_dim: (row0 + in_dim) as u16,
        out_dim: *od as u16,
        act_max: 0.0,
        weights,
        bias: &[],
        scales: &[],
        requant: &[],
    };
    let mut acc = [[0.25f32; MAX_WIDTH]; 8];
    kernel(&l, Input { rows: &input[..], row0: *row0, width: *in_dim, n: *n }, &mut acc);
    acc.iter().map(|r| r.map(f32::to_bits)).collect()
}

fn f32_layer_reference(c: &F32Case) -> Vec<[u32; MAX_WIDTH]> {
    f32_layer_with(c, |l, x, acc| accumulate::<MacF32, MAX_WIDTH>(l, 0, x, acc))
}

fn f32_layer_selected(_: (), c: &F32Case) -> Vec<[u32; MAX_WIDTH]> {
    f32_layer_with(c, accumulate_f32)
}

#[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
fn f32_layer_avx2(k: avx2::Avx2, c: &F32Case) -> Vec<[u32; MAX_WIDTH]> {
    f32_layer_with(c, |l, x, acc| avx2::accumulate_f32(k, l, x, acc))
}

// ---- requantisation of i32 accumulators

/// Requantisation constants of one layer and the bounds to clamp to.
struct RequantCase {
    requant: Vec<u8>,
    od: usize,
    n: usize,
    bounds: (i16, i16),
    acc: [[i32; MAX_WIDTH]; 8],
}

/// Every shift, multipliers at the ends of their range, accumulators at
/// the ends of i32, the ReLU and linear bounds of both activation widths;
/// 67 outputs (16 groups of 4 and a remainder).
fn requant_cases() -> Vec<RequantCase> {
    let mut next = rng(0x2545_f491);
    let od = 67;
    let mut acc = [[0i32; MAX_WIDTH]; 8];
    let edges = [i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX];
    for (s, row) in acc.iter_mut().enumerate() {
        for (c, a) in row[..od].iter_mut().enumerate() {
            *a = if (s + c) % 5 == 0 { edges[(s * 7 + c) % edges.len()] } else { next() as i32 >> (next() % 31) };
        }
    }
    let mut cases = Vec::new();
    for shift in Requant::MIN_SHIFT..=Requant::MAX_SHIFT {
        let mut requant = Vec::new();
        for c in 0..od {
            let multiplier = match c % 4 {
                0 => 1 << 30,
                1 => i32::MAX,
                2 if shift == 0 => 0,
                _ => (1 << 30) + (next() as i32 & 0x3fff_ffff),
            };
            requant.extend_from_slice(&multiplier.to_le_bytes());
            requant.extend_from_slice(&shift.to_le_bytes());
        }
        for bounds in [(0, i16::MAX), (0, 255), (i16::MIN, i16::MAX), (-127, 127)] {
            for n in [1, 5, 8] {
                cases.push(RequantCase { requant: requant.clone(), od, n, bounds, acc });
            }
        }
    }
    cases
}

/// Runs `kernel` on the case's layer into rows starting at a marker.
fn requant_with(
    c: &RequantCase,
    kernel: impl Fn(&Layer<'_>, &RequantCase, &mut [[i16; MAX_WIDTH]]),
) -> Vec<[i16; MAX_WIDTH]> {
    let l = Layer {
        in_dim: 1,
        out_dim: c.od as u16,
        act_max: 0.0,
        weights: &[],
        bias: &[],
        scales: &[],
        requant: &c.requant,
    };
    let mut out = std::vec![[0x5555i16; MAX_WIDTH]; 8];
    kernel(&l, c, &mut out);
    out
}

fn requant_reference(c: &RequantCase) -> Vec<[i16; MAX_WIDTH]> {
    requant_with(c, |l, c, out| requant_rows::<W8>(l, 0, c.n, &c.acc, out, c.bounds))
}

fn requant_selected(_: (), c: &RequantCase) -> Vec<[i16; MAX_WIDTH]> {
    requant_with(c, |l, c, out| W8::requant_rows(l, c.n, &c.acc, out, c.bounds))
}

#[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
fn requant_avx2(k: avx2::Avx2, c: &RequantCase) -> Vec<[i16; MAX_WIDTH]> {
    requant_with(c, |l, c, out| avx2::requant_i32(k, l, c.n, &c.acc, out, c.bounds))
}

#[cfg(all(
    target_arch = "x86_64",
    any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
))]
fn requant_vnni(k: vnni::Vnni, c: &RequantCase) -> Vec<[i16; MAX_WIDTH]> {
    requant_with(c, |l, c, out| vnni::requant_i32(k, l, c.n, &c.acc, out, c.bounds))
}

same_as_reference! {
    selected_sine(Some(())): sine_cases(), sine_selected, sine_reference;
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    avx2_sine(avx2::Avx2::new()): sine_cases(), sine_avx2, sine_reference;

    selected_int8_layer(Some(())): layer_cases(), layer_selected, layer_reference;
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    avx2_int8_layer(avx2::Avx2::new()): layer_cases(), layer_avx2, layer_reference;
    #[cfg(all(
    target_arch = "x86_64",
    any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
))]
    vnni_int8_layer(vnni::Vnni::new()): layer_cases(), layer_vnni, layer_reference;

    selected_f32_layer(Some(())): f32_layer_cases(), f32_layer_selected, f32_layer_reference;
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    avx2_f32_layer(avx2::Avx2::new()): f32_layer_cases(), f32_layer_avx2, f32_layer_reference;

    selected_int8_requantisation(Some(())): requant_cases(), requant_selected, requant_reference;
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    avx2_int8_requantisation(avx2::Avx2::new()): requant_cases(), requant_avx2, requant_reference;
    #[cfg(all(
    target_arch = "x86_64",
    any(feature = "std", all(target_feature = "avx512bw", target_feature = "avx512vnni"))
))]
    vnni_int8_requantisation(vnni::Vnni::new()): requant_cases(), requant_vnni, requant_reference;

    selected_feature_lookups(Some(())): feature_cases(), features_selected, features_reference;
    #[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
    avx2_feature_lookups(avx2::Avx2::new()): feature_cases(), features_avx2, features_reference;
}

/// The requantisation reference itself against `Requant::apply` and a
/// clamp, so that the chain of equalities ends in the definition.
#[test]
fn requantisation_reference_is_requant_apply_then_clamp() {
    for c in requant_cases() {
        let out = requant_reference(&c);
        let l = requant_with(&c, |_, _, _| {});
        let rq = |k: usize| i32::from_le_bytes(c.requant[8 * k..8 * k + 4].try_into().unwrap());
        let sh = |k: usize| i32::from_le_bytes(c.requant[8 * k + 4..8 * k + 8].try_into().unwrap());
        for s in 0..8 {
            for k in 0..c.od {
                let want = if s < c.n {
                    let r = Requant { multiplier: rq(k), shift: sh(k) };
                    r.apply(c.acc[s][k] as i64).clamp(c.bounds.0 as i64, c.bounds.1 as i64) as i16
                } else {
                    l[s][k]
                };
                assert_eq!(out[s][k], want, "s {s} c {k}");
            }
        }
    }
}
