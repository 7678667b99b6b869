//! Corrupted model files: every truncation and thousands of bit flips give
//! a typed error or a model that renders finite, in-range pixels — never a
//! panic. Flips are tried with the checksum left stale (caught by the CRC)
//! and with it recomputed, so that decoding and validation are exercised.

use nerf_infer::format::{crc32, HEADER_LEN};
use nerf_infer::sampling::hash32;
use nerf_infer::{Camera, Error, Model, RayRenderer, RenderOptions, RendererFixed, ScratchFixed};

const BLOB: &[u8] = include_bytes!("data/golden.nerf");

fn render_a_few(m: &Model<'_>) {
    let Ok(r) = RendererFixed::new(m, RenderOptions::from_model(m)) else { return };
    let pose = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 3.0]];
    let cam = Camera::from_fov(4, 4, 0.7, pose).unwrap();
    let mut s = Box::new(ScratchFixed::<2>::default());
    for (x, y) in [(0, 0), (2, 2), (3, 1)] {
        let (o, d) = cam.ray(x, y);
        let p = r.render_ray(o, d, (x, y), &mut *s);
        assert!(p.rgb.iter().all(|&c| c <= 32768) && p.opacity <= 32768);
    }
}

#[test]
fn every_truncation_is_a_typed_error() {
    for n in 0..BLOB.len() {
        let e = Model::from_bytes(&BLOB[..n]).unwrap_err();
        assert!(matches!(e, Error::Truncated | Error::BadMagic), "length {n}: {e:?}");
    }
    assert!(Model::from_bytes(BLOB).is_ok());
    let mut longer = BLOB.to_vec();
    longer.push(0);
    assert_eq!(Model::from_bytes(&longer).unwrap_err(), Error::TrailingBytes);
}

#[test]
fn random_bit_flips_never_panic() {
    let mut decoded = 0;
    for k in 0..4000u32 {
        let mut b = BLOB.to_vec();
        let flips = 1 + hash32(k) % 3;
        for f in 0..flips {
            let h = hash32(k.wrapping_mul(7919) ^ f);
            let pos = (h as usize >> 3) % b.len();
            b[pos] ^= 1 << (h & 7);
        }
        if k % 2 == 1 && b.len() > HEADER_LEN {
            let crc = crc32(&b[HEADER_LEN..]);
            b[10..14].copy_from_slice(&crc.to_le_bytes());
        } else if b != BLOB {
            assert!(Model::from_bytes(&b).is_err(), "flip {k} passed a stale checksum");
        }
        if let Ok(m) = Model::from_bytes(&b) {
            decoded += 1;
            render_a_few(&m);
        };
    }
    // most flips with a fixed-up CRC land in weights and still decode
    assert!(decoded > 500, "only {decoded} decodable variants exercised rendering");
}

#[allow(dead_code)]
#[path = "../fuzz/decode_render_check.rs"]
mod fuzz_check;

#[test]
fn fuzz_seeds_and_found_crashes_stay_fixed() {
    // Inputs the fuzz target (`fuzz/`, cargo-fuzz on nightly) starts from or
    // once crashed on, replayed through the same check on stable.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut n = 0;
    for sub in ["seeds", "regressions"] {
        for entry in std::fs::read_dir(dir.join(sub)).unwrap() {
            let path = entry.unwrap().path();
            fuzz_check::run(&std::fs::read(&path).unwrap());
            n += 1;
        }
    }
    assert!(n >= 5, "{n} inputs");
}
