//! The cost of the fixed-point feature lookups (`arch::feature_rows`, the
//! kernels the int8 and int16 renders use) against the size of the table,
//! so that the time the corners' reads lose to cache misses can be told
//! from the time of the lookups' own instructions:
//!
//!     cargo run -p nerf-infer --release --example lookup_cost
//!
//! Two grids: the default's at 100×100 (8 levels of 2 values, 16 to 256
//! cells per axis, 2^15 entries per level) and at 800×800 (16 levels, 16
//! to 2048 cells, 2^18 entries), each also with fewer entries per level
//! down to 2^9 (the same work on a table that stays in the caches); i16
//! values or 8-bit indices into a codebook (`--table-bits 8`), random
//! values. The points are those a ray's block asks for: 20 000 rays from
//! random origins in random directions, 8 samples 1/96 of the box apart,
//! 3 footprint points each (24 points per call, as the default renders).
//! Prints nanoseconds per point (one thread, the fastest of 15 passes).

use nerf_infer::arch::feature_rows;
use nerf_infer::features::{geometric_resolutions, FeatureGrid, NarrowTable};
use std::hint::black_box;
use std::time::Instant;

/// A 64-bit linear congruential generator's next value, top 32 bits.
fn next(s: &mut u64) -> u32 {
    *s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
    (*s >> 32) as u32
}

/// A uniform value in `[lo, hi)`.
fn uniform(s: &mut u64, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * (next(s) as f32 / 4_294_967_296.0)
}

/// Q24 positions of `rays` rays' blocks: 8 samples, 3 footprint points each.
fn points(rays: usize, s: &mut u64) -> Vec<[i32; 3]> {
    let mut pos = Vec::with_capacity(rays * 24);
    for _ in 0..rays {
        let o: [f32; 3] = core::array::from_fn(|_| uniform(s, -0.8, 0.8));
        let d: [f32; 3] = core::array::from_fn(|_| uniform(s, -1.0, 1.0));
        let n = d.iter().map(|v| v * v).sum::<f32>().sqrt().max(1e-6);
        for k in 0..8 {
            for f in 0..3 {
                let t = (k as f32 + 0.3 * f as f32) * 2.0 / 192.0;
                pos.push(core::array::from_fn(|a| ((o[a] + d[a] / n * t).clamp(-1.0, 1.0) * 16_777_216.0) as i32));
            }
        }
    }
    pos
}

fn main() {
    let mut s = 7u64;
    let pos = points(20_000, &mut s);
    println!("| levels | cells per axis | entries per level | table values | table KiB | ns per point |");
    println!("|--:|--:|--:|---|--:|--:|");
    // (levels, finest cells per axis, log2 of the entries per level)
    let grids =
        [(8, 256, 15), (8, 256, 12), (8, 256, 9), (16, 2048, 18), (16, 2048, 16), (16, 2048, 12), (16, 2048, 9)];
    for (levels, max_res, log2_table, narrow) in
        grids.into_iter().flat_map(|(l, r, t)| [(l, r, t, false), (l, r, t, true)])
    {
        let shape = FeatureGrid {
            width: 2,
            log2_table,
            frac_bits: 12,
            resolutions: geometric_resolutions(levels, 16, max_res),
            table: &[],
            narrow: None,
        };
        let values = shape.values();
        // i16 values in [0, 64) or 8-bit indices (the table padded to whole words), codes in [0, 64)
        let table: Vec<u8> = if narrow {
            (0..values.div_ceil(4) * 4).map(|_| next(&mut s) as u8).collect()
        } else {
            (0..values).flat_map(|_| [(next(&mut s) % 64) as u8, 0]).collect()
        };
        let codebook: Vec<u8> = (0..shape.levels() * 256).flat_map(|_| [(next(&mut s) % 64) as u8, 0]).collect();
        let g = FeatureGrid {
            table: &table,
            narrow: narrow.then_some(NarrowTable { bits: 8, codebook: &codebook }),
            ..shape.clone()
        };
        assert!(g.is_valid(2), "a valid grid");
        let mut out = vec![[0i16; 32]; 24];
        let mut best = f64::MAX;
        for _ in 0..15 {
            let t0 = Instant::now();
            for block in pos.chunks(24) {
                feature_rows(&g, block, &mut out, 0);
                black_box(&out);
            }
            best = best.min(t0.elapsed().as_secs_f64());
        }
        let kind = if narrow { "8-bit indices" } else { "i16" };
        let ns = best * 1e9 / pos.len() as f64;
        println!("| {levels} | 16–{max_res} | 2^{log2_table} | {kind} | {} | {ns:.1} |", table.len() / 1024);
    }
}
