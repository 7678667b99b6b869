//! Cases of the feature-grid lookup kernels: width-2 grids, i16 and
//! narrow tables, positions across every level.

use super::*;

/// A width-2 grid's table (and a narrow table's bits and codebook) and
/// the positions to look up.
pub(super) struct FeatureCase {
    table: Vec<u8>,
    narrow: Option<(u8, Vec<u8>)>,
    levels: usize,
    min: u16,
    max: u16,
    log2: u8,
    pos: [[i32; 3]; 64],
}

impl FeatureCase {
    fn grid(&self) -> FeatureGrid<'_> {
        FeatureGrid {
            width: 2,
            log2_table: self.log2,
            frac_bits: 9,
            resolutions: geometric_resolutions(self.levels, self.min, self.max),
            table: &self.table,
            narrow: self.narrow.as_ref().map(|(bits, codebook)| NarrowTable { bits: *bits, codebook }),
        }
    }
}

/// Dense and hashed levels, one and two register groups, extreme table
/// values; i16 tables and narrow ones (8- and 4-bit indices, each level's
/// codebook with the extreme i16 values); tables of 12 and 6 MiB, whose
/// corners the AVX2 kernel prefetches ahead (lego's grid at 800×800);
/// positions beyond the bounds, on the faces and at vertices.
pub(super) fn feature_cases() -> Vec<FeatureCase> {
    let shapes = [(3, 2, 9, 6), (8, 16, 256, 10), (16, 1, 4096, 10), (9, 4, 600, 8), (16, 16, 2048, 18)];
    let one = 1i32 << NPOS_FRAC;
    let mut cases = Vec::new();
    for (shape, bits) in (0..shapes.len()).flat_map(|s| [(s, 16u8), (s, 8), (s, 4)]) {
        let (levels, min, max, log2) = shapes[shape];
        let mut case = FeatureCase { table: Vec::new(), narrow: None, levels, min, max, log2, pos: [[0; 3]; 64] };
        let values = case.grid().values();
        let byte = |b: usize| {
            let h = (b as u32 ^ (shape as u32) << 20 ^ (bits as u32) << 26).wrapping_mul(0x9E37_79B9);
            if shape == 2 {
                [0x00, 0x80, 0xFF, 0x7F][(h >> 30) as usize]
            } else {
                (h >> 24) as u8
            }
        };
        if bits == 16 {
            case.table = (0..2 * values).map(byte).collect();
        } else {
            let narrow = NarrowTable { bits, codebook: &[] };
            case.table = (0..narrow.bytes(values)).map(byte).collect();
            let codebook = (0..levels << bits)
                .flat_map(|k| {
                    match k % (1 << bits) {
                        0 => i16::MIN,
                        q if q == (1 << bits) - 1 => i16::MAX,
                        _ => (byte(k + 7) as i16) << 8 | byte(k + 11) as i16,
                    }
                    .to_le_bytes()
                })
                .collect();
            case.narrow = Some((bits, codebook));
        }
        assert!(case.grid().is_valid(2));
        for (k, p) in case.pos.iter_mut().enumerate() {
            let h = |s: u32| (k as u32 ^ s << 8).wrapping_mul(2_654_435_761).rotate_left(s) as i32;
            *p = match k % 4 {
                0 => [h(1), h(2), h(3)],
                1 => [h(4) >> 7, h(5) >> 7, h(6) >> 7],
                2 => [one, -one, (h(7) >> 7).clamp(-one, one) / 4096 * 4096],
                _ => [h(8) >> 8, one - 1, -one + 1],
            };
        }
        cases.push(case);
    }
    cases
}

/// Rows of 40 values with the features at 5.. (the rest must stay 0).
pub(super) fn features_with(
    c: &FeatureCase,
    kernel: impl Fn(&FeatureGrid<'_>, &[[i32; 3]], &mut [[i16; 40]]),
) -> Vec<[i16; 40]> {
    let mut rows = std::vec![[0i16; 40]; 64];
    kernel(&c.grid(), &c.pos, &mut rows);
    rows
}

pub(super) fn features_reference(c: &FeatureCase) -> Vec<[i16; 40]> {
    features_with(c, |g, pos, rows| {
        for (p, row) in pos.iter().zip(rows.iter_mut()) {
            g.encode_fixed(*p, &mut row[5..5 + g.dim()]);
        }
    })
}

pub(super) fn features_selected(_: (), c: &FeatureCase) -> Vec<[i16; 40]> {
    features_with(c, |g, pos, rows| feature_rows(g, pos, rows, 5))
}

#[cfg(all(target_arch = "x86_64", any(feature = "std", target_feature = "avx2")))]
pub(super) fn features_avx2(k: avx2::Avx2, c: &FeatureCase) -> Vec<[i16; 40]> {
    features_with(c, |g, pos, rows| avx2::features_w2(k, g, pos, rows, 5))
}
