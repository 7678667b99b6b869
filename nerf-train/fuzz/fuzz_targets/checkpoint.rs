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
        nerf_infer::format::frame(CHECKPOINT_MAGIC, CHECKPOINT_VERSION, body).expect("a fuzz input is under 4 GiB")
    } else {
        body.to_vec()
    };
    if let Ok(t) = Trainer::from_bytes(&bytes) {
        // an accepted state serialises again
        assert!(!t.to_bytes().expect("an accepted state encodes").is_empty());
    }
});
