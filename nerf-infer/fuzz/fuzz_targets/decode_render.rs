//! Fuzzes `Model::from_bytes` and rendering whatever it accepts.
//!
//! Input: one control byte, then the model file. Control bit 0 set: the
//! header's magic, version, length and CRC-32 are rewritten to match the
//! payload, so mutations reach the postcard decoder and model validation
//! instead of stopping at the checksum. The other bits pick sample counts,
//! early termination and jitter. An accepted model is rendered by its
//! numeric path on a few pixels and on hostile rays (NaN, infinite, zero,
//! axis-parallel, far outside the bounds); every pixel must be finite and in
//! range (`../decode_render_check.rs`, shared with the stable test that
//! replays `seeds/` and `regressions/`). Run from `nerf-infer/`:
//! `cargo +nightly fuzz run decode_render fuzz/corpus/decode_render fuzz/seeds`
//! (new inputs go to the untracked `fuzz/corpus/`).
#![no_main]

include!("../decode_render_check.rs");

libfuzzer_sys::fuzz_target!(|data: &[u8]| run(data));
