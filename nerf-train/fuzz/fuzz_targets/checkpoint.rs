//! Fuzzes checkpoint loading (`Trainer::from_bytes`). Input: one control
//! byte, then the checkpoint. Control bit 0 set: the input is wrapped in a
//! header whose length and CRC-32 match, so mutations reach the decoder and
//! the consistency checks instead of stopping at the checksum. Run from
//! `nerf-train/`: `cargo +nightly fuzz run checkpoint`.
#![no_main]

use nerf_train::train::{Trainer, CHECKPOINT_MAGIC, CHECKPOINT_VERSION};

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((&ctl, body)) = data.split_first() else { return };
    let bytes = if ctl & 1 == 1 {
        let mut b = CHECKPOINT_MAGIC.to_vec();
        b.extend_from_slice(&CHECKPOINT_VERSION.to_le_bytes());
        b.extend_from_slice(&(body.len() as u64).to_le_bytes());
        b.extend_from_slice(&nerf_infer::format::crc32(body).to_le_bytes());
        b.extend_from_slice(body);
        b
    } else {
        body.to_vec()
    };
    if let Some(t) = Trainer::from_bytes(&bytes) {
        // an accepted state serialises again
        assert!(!t.to_bytes().is_empty());
    }
});
