//! Fuzzes the NPY reader of LLFF's `poses_bounds.npy`: any input gives an
//! array or an error. Run from `nerf-train/`: `cargo +nightly fuzz run npy`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Ok((rows, cols, vals)) = nerf_train::dataset::parse_npy_f64(std::path::Path::new("fuzz"), data) {
        assert_eq!(rows * cols, vals.len());
    }
});
