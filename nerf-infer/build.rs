//! `cfg(arm_dsp)` on targets whose every core has the Armv7E-M DSP
//! extension (`thumbv7em-*`: Cortex-M4, M7). The int16 dense kernel writes
//! its multiply-accumulate in the form each instruction set compiles best
//! (`smlalbb` there, `smlal` on other cores); `target_feature = "dsp"` is
//! not visible to `cfg` on stable Rust.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(arm_dsp)");
    println!("cargo::rerun-if-changed=build.rs");
    if std::env::var("TARGET").is_ok_and(|t| t.starts_with("thumbv7em")) {
        println!("cargo::rustc-cfg=arm_dsp");
    }
}
