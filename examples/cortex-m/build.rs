//! Picks the board's memory map by target: `thumbv7m-none-eabi` runs on the
//! lm3s6965evb (Cortex-M3), `thumbv7em-none-eabihf` on the mps2-an386
//! (Cortex-M4F). With `NERF_MODEL` (a model file) and `NERF_MODEL_EXPECTED`
//! (the host's render of the tile, as `run --model` writes it), the
//! firmware renders that model instead of the shipped ones (`cfg(user_model)`).

use std::{env, fs, path::PathBuf};

fn main() {
    let target = env::var("TARGET").expect("cargo sets TARGET");
    let board = match target.as_str() {
        "thumbv7m-none-eabi" => "lm3s6965evb",
        "thumbv7em-none-eabihf" => "mps2-an386",
        other => panic!("no board for target {other}: build for thumbv7m-none-eabi or thumbv7em-none-eabihf"),
    };
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::copy(format!("memory-{board}.x"), out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-env=NERF_BOARD={board}");
    println!("cargo:rerun-if-changed=memory-{board}.x");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(user_model)");
    println!("cargo:rerun-if-env-changed=NERF_MODEL");
    println!("cargo:rerun-if-env-changed=NERF_MODEL_EXPECTED");
    if let (Ok(model), Ok(expected)) = (env::var("NERF_MODEL"), env::var("NERF_MODEL_EXPECTED")) {
        fs::copy(&model, out.join("user_model.nerf")).unwrap_or_else(|e| panic!("NERF_MODEL {model}: {e}"));
        fs::copy(&expected, out.join("user_expected.rs"))
            .unwrap_or_else(|e| panic!("NERF_MODEL_EXPECTED {expected}: {e}"));
        println!("cargo:rerun-if-changed={model}");
        println!("cargo:rerun-if-changed={expected}");
        println!("cargo:rustc-cfg=user_model");
    }
}
