//! Fuzzes the six COLMAP model parsers (`cameras`, `images`, `points3D`,
//! binary and text). Input: one selector byte, then the file's bytes.
//! Every input must give a model or an error, never a panic or an
//! allocation beyond the input's size. Run from `nerf-train/`:
//! `cargo +nightly fuzz run colmap`.
#![no_main]

use nerf_train::dataset::colmap_io::*;
use std::path::Path;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((&sel, bytes)) = data.split_first() else { return };
    let p = Path::new("fuzz");
    let _ = match sel % 6 {
        0 => parse_cameras_bin(p, bytes).map(|_| ()),
        1 => parse_images_bin(p, bytes).map(|_| ()),
        2 => parse_points_bin(p, bytes).map(|_| ()),
        3 => parse_cameras_txt(p, bytes).map(|_| ()),
        4 => parse_images_txt(p, bytes).map(|_| ()),
        _ => parse_points_txt(p, bytes).map(|_| ()),
    };
});
