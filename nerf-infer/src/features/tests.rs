//! Lattices, weights and lookups of the feature grid: dense levels index
//! every vertex once, fixed-point lookups match f32 within rounding,
//! narrow tables read their codebooks.

use super::*;

/// Values of the test grid: levels of 2, 4, 9 cells with 2⁶ entries at
/// most: 27 (dense) + 64 (hashed: 125 vertices) + 64 (hashed), 2 each.
const N: usize = (27 + 64 + 64) * 2;

fn grid<'a>(table: &'a [u8], frac_bits: u8) -> FeatureGrid<'a> {
    FeatureGrid { width: 2, log2_table: 6, frac_bits, resolutions: geometric_resolutions(3, 2, 9), table, narrow: None }
}

#[test]
fn resolutions_span_min_to_max() {
    assert_eq!(geometric_resolutions(3, 2, 9).as_slice(), &[2, 4, 9]);
    assert_eq!(geometric_resolutions(1, 16, 512).as_slice(), &[16]);
    assert_eq!(*geometric_resolutions(16, 16, 512).last().unwrap(), 512);
    let g = grid(&[], 0);
    assert_eq!((g.entries(0), g.entries(1), g.offset(2), g.values()), (27, 64, 91, N));
    assert!(grid(&[0; 2 * N], 3).is_valid(2) && !grid(&[0; 2 * N - 2], 3).is_valid(2));
}

#[test]
fn dense_levels_index_every_vertex_once() {
    let g = grid(&[], 0);
    // level 0: 3³ = 27 vertices ≤ 64 entries: dense and distinct
    let mut seen = [false; 64];
    for k in 0..3 {
        for j in 0..3 {
            for i in 0..3 {
                let e = g.entry(2, [i, j, k]) as usize;
                assert!(!seen[e]);
                seen[e] = true;
            }
        }
    }
    // level 2: 10³ > 64: hashed into the table
    assert!((0..10).all(|i| g.entry(9, [i, 9 - i, i / 2]) < 64));
}

#[test]
fn weights_sum_to_one_and_vertices_reproduce_the_table() {
    let vals: [f32; N] = core::array::from_fn(|i| ((i * 37 % 101) as f32 - 50.0) / 64.0);
    let bytes: [u8; 4 * N] = core::array::from_fn(|b| vals[b / 4].to_le_bytes()[b % 4]);
    let g = grid(&bytes, 0);
    for k in 0..50 {
        let p = [k as f32 / 25.0 - 1.0, 0.3 - k as f32 / 70.0, (k as f32 * 0.7).sin()];
        for l in 0..3 {
            let s: f32 = g.corners_f32(l, p).weight.iter().sum();
            assert!((s - 1.0).abs() < 1e-5);
        }
    }
    // at a lattice vertex the feature is that vertex's entry
    let mut out = [0.0f32; 6];
    g.encode_f32([0.0, -1.0, 1.0], &mut out);
    let e = g.entry(2, [1, 0, 2]) as usize;
    assert_eq!(out[0], vals[2 * e]);
    assert_eq!(out[1], vals[2 * e + 1]);
}

#[test]
fn extreme_tables_neither_overflow_nor_wrap() {
    // every weight rounding up at once is the worst case for the i32 sum
    for v in [i16::MIN, i16::MAX] {
        let qb: [u8; 2 * N] = core::array::from_fn(|b| v.to_le_bytes()[b % 2]);
        let g = grid(&qb, 15);
        let mut out = [0i16; 6];
        for k in 0..3000u32 {
            let h = |s: u32| (k.wrapping_mul(2_654_435_761) ^ s).wrapping_mul(0x9E37_79B9) as i32 >> 6;
            g.encode_fixed([h(1), h(2), h(3)], &mut out);
            assert!(out.iter().all(|&o| (o as i32 - v as i32).abs() <= 4), "{out:?} for a table of {v}");
        }
    }
}

#[test]
fn fixed_features_match_f32_within_rounding() {
    let fb = 12u8;
    let q: [i16; N] = core::array::from_fn(|i| ((i * 7919 % 8191) as i16 - 4095) * 7);
    let qb: [u8; 2 * N] = core::array::from_fn(|b| q[b / 2].to_le_bytes()[b % 2]);
    let fbytes: [u8; 4 * N] = core::array::from_fn(|b| (q[b / 4] as f32 / (1 << fb) as f32).to_le_bytes()[b % 4]);
    let (gq, gf) = (grid(&qb, fb), grid(&fbytes, 0));
    let (mut oq, mut of) = ([0i16; 6], [0.0f32; 6]);
    let max_t = q.iter().map(|v| v.unsigned_abs()).max().unwrap() as f32;
    let mut sum_err = 0.0f64;
    for k in 0..2000 {
        let t = k as f32 * 0.001_37;
        // includes points outside the bounds (clamped to the faces)
        let p = [(t * 3.1).sin() * 1.1, (t * 1.7).cos(), t - 1.4];
        let pq = p.map(|v| libm::roundf(v * (1 << NPOS_FRAC) as f32) as i32);
        let pr = pq.map(|v| v as f32 / (1 << NPOS_FRAC) as f32);
        gq.encode_fixed(pq, &mut oq);
        gf.encode_f32(pr, &mut of);
        for j in 0..6 {
            let want = of[j] * (1 << fb) as f32;
            let err = (oq[j] as f32 - want).abs();
            // the bound of encode_fixed's doc, + the f32 reference's own error
            assert!(err <= 0.5 + 7.0 * max_t / 32768.0 + 0.05, "k {k} feature {j}: {} vs {want}", oq[j]);
            sum_err += err as f64;
        }
    }
    // typically within a step (rounding errors of both signs cancel)
    let mean = sum_err / (2000.0 * 6.0);
    assert!(mean < 0.6, "mean error {mean:.3} output steps");
}

/// A narrow table's features are those of the i16 table holding each
/// index's codebook value: 8- and 4-bit indices (the even value of a
/// byte in its low nibble), each level its own codebook, extreme codes
/// included; widths 2 and 1 (155 values: an odd count, the last byte's
/// high nibble unused), the tables padded to whole 4-byte words.
#[test]
fn narrow_indices_read_their_level_codebooks_like_an_i16_table() {
    for (bits, width) in [(8u8, 2u8), (4, 2), (8, 1), (4, 1)] {
        let codes = 1usize << bits;
        // level l, index q: a distinct value per level, the extremes at both ends
        let code = |l: usize, q: usize| match q {
            0 => i16::MIN,
            q if q == codes - 1 => i16::MAX,
            q => (q as i32 * 97 - 600 + l as i32 * 1000) as i16,
        };
        let codebook: [u8; 3 * 256 * 2] =
            core::array::from_fn(|b| code(b / 2 / codes, b / 2 % codes).to_le_bytes()[b % 2]);
        let codebook = &codebook[..3 * codes * 2];
        let g = FeatureGrid { width, ..grid(&[], 13) };
        let n = g.values();
        let index: [usize; N] = core::array::from_fn(|k| ((k * 2_654_435_761usize) >> 7) % codes);
        let at = |k: usize| if k < n { index[k] } else { 0 };
        // padded with zeros to whole 4-byte words
        let packed: [u8; N + 4] =
            core::array::from_fn(|b| if bits == 8 { at(b) as u8 } else { (at(2 * b) | at(2 * b + 1) << 4) as u8 });
        let packed = &packed[..(n * bits as usize).div_ceil(32) * 4];
        let level_of = |k: usize| (0..3).rfind(|&l| k >= g.offset(l) * width as usize).unwrap();
        let wide: [u8; 2 * N] = core::array::from_fn(|b| code(level_of(b / 2), index[b / 2]).to_le_bytes()[b % 2]);
        let narrow = NarrowTable { bits, codebook };
        let gn = FeatureGrid { narrow: Some(narrow), table: packed, ..g.clone() };
        let gw = FeatureGrid { table: &wide[..2 * n], ..g.clone() };
        assert!(gn.is_valid(2) && gw.is_valid(2), "{bits}-bit indices, width {width}");
        assert_eq!(gn.table_bytes(2), (n * bits as usize).div_ceil(32) * 4);
        let (mut on, mut ow) = ([0i16; 6], [0i16; 6]);
        let dim = g.dim();
        for k in 0..3000u32 {
            let h = |s: u32| (k.wrapping_mul(2_654_435_761) ^ s).wrapping_mul(0x9E37_79B9) as i32 >> 6;
            gn.encode_fixed([h(1), h(2), h(3)], &mut on[..dim]);
            gw.encode_fixed([h(1), h(2), h(3)], &mut ow[..dim]);
            assert_eq!(on, ow, "{bits}-bit indices, width {width}, position {k}");
        }
        // at the finest level's top corner the feature is that vertex's code, exactly
        gn.encode_fixed([1 << NPOS_FRAC; 3], &mut on[..dim]);
        let last = g.entry(9, [9, 9, 9]) as usize + g.offset(2);
        assert_eq!(on[dim - width as usize], code(2, index[last * width as usize]));
        // a table or codebook of the wrong length, or other bits, is refused
        assert!(!FeatureGrid { table: &packed[1..], ..gn.clone() }.is_valid(2));
        let short = NarrowTable { codebook: &codebook[2..], ..narrow };
        assert!(!FeatureGrid { narrow: Some(short), ..gn.clone() }.is_valid(2));
        for other in [0, 6, 16] {
            assert!(!FeatureGrid { narrow: Some(NarrowTable { bits: other, ..narrow }), ..gn.clone() }.is_valid(2));
        }
    }
}

/// A narrow table fills whole 4-byte words: 27 values take 16 bytes of
/// 4-bit indices (14 unpadded) or 28 of 8-bit ones (27 unpadded).
#[test]
fn narrow_tables_are_padded_to_whole_words() {
    let codebook = [0u8; 2 * 256];
    let bytes = [0u8; 32];
    // one level of 2 cells per axis: 27 dense vertices of 1 value
    let g = FeatureGrid {
        width: 1,
        log2_table: 5,
        frac_bits: 8,
        resolutions: geometric_resolutions(1, 2, 2),
        table: &[],
        narrow: None,
    };
    assert_eq!(g.values(), 27);
    for (bits, padded, unpadded) in [(4u8, 16, 14), (8, 28, 27)] {
        let narrow = Some(NarrowTable { bits, codebook: &codebook[..2 << bits] });
        assert!(FeatureGrid { table: &bytes[..padded], narrow, ..g.clone() }.is_valid(2), "{bits} bits");
        for len in [unpadded, padded - 1, padded + 4] {
            assert!(!FeatureGrid { table: &bytes[..len], narrow, ..g.clone() }.is_valid(2), "{bits} bits, {len} B");
        }
    }
}
