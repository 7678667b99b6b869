//! Fuzzes the instant-ngp / Blender loaders: the input is written as
//! `transforms.json` (and as `transforms_train.json` in a second folder)
//! beside a 4×4 PNG named `a.png`, and every split is loaded with lens
//! distortion on. Any input gives a dataset or an error naming the file.
//! Run from `nerf-train/`: `cargo +nightly fuzz run transforms`.
#![no_main]

use nerf_train::dataset::{load, Format, LoadOptions, Split};
use std::path::PathBuf;
use std::sync::OnceLock;

fn dirs() -> &'static (PathBuf, PathBuf) {
    static D: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    D.get_or_init(|| {
        let root = std::env::temp_dir().join(format!("nerf-fuzz-transforms-{}", std::process::id()));
        let (ngp, blender) = (root.join("ngp"), root.join("blender"));
        for d in [&ngp, &blender] {
            std::fs::create_dir_all(d).unwrap();
            image::RgbImage::from_pixel(4, 4, image::Rgb([200, 100, 50])).save(d.join("a.png")).unwrap();
        }
        (ngp, blender)
    })
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let (ngp, blender) = dirs();
    std::fs::write(ngp.join("transforms.json"), data).unwrap();
    std::fs::write(blender.join("transforms_train.json"), data).unwrap();
    for (dir, format) in [(ngp, Format::Ngp), (blender, Format::Blender)] {
        for split in [Split::Train, Split::Test] {
            let opts = LoadOptions { format, downscale: 1, holdout: 2, ..LoadOptions::default() };
            if let Ok(d) = load(dir, split, opts) {
                for v in &d.views {
                    let _ = v.ray(0, 0);
                    let _ = v.ray(3, 3);
                }
            }
        }
    }
});
