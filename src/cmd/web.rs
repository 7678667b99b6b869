//! `nerf web`: a static page that renders a model in the browser with the
//! `nerf-infer` renderer compiled to WebAssembly (`nerf-web`): orbit with
//! mouse or touch, zoom with the wheel, µs per ray and frames per second
//! shown; a moving view is drawn small and scaled up, a resting one at the
//! chosen size. Opened with `?check=1` it renders the first view of the
//! model's orbit at 64×64 and writes a JSON object into the element
//! `#result` (docs/CLI.md lists its fields): `crc32` is the CRC-32 of the
//! frame's RGB bytes, which `nerf render MODEL --orbit 1 --size 64` writes
//! as PNG.

use super::{create_dir, decode, read_model, write_atomic, CmdError, CmdResult};
use nerf_infer::Orbit;
use std::path::PathBuf;

/// Arguments of `nerf web`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model file (.nerf); int8 renders fastest.
    pub(crate) model: PathBuf,
    /// Output folder (new, empty, or an earlier page's): index.html, nerf_web.wasm, model.nerf, view.json; serve
    /// it with any static file server (e.g. `python3 -m http.server -d DIR`) and open index.html.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Replace what nerf wrote in the output folder before (another command's outputs, as its
    /// `.nerf-outputs` record lists them); files nerf did not write are never removed.
    #[arg(long)]
    pub(crate) force: bool,
}

/// The page.
const PAGE: &str = include_str!("../../nerf-web/page/index.html");
/// The side of the `?check=1` frame, pixels.
const CHECK_SIZE: u32 = 64;

/// The WebAssembly module, built by build.rs.
#[cfg(web_viewer)]
fn module() -> CmdResult<&'static [u8]> {
    Ok(include_bytes!(concat!(env!("OUT_DIR"), "/nerf_web.wasm")))
}

#[cfg(not(web_viewer))]
fn module() -> CmdResult<&'static [u8]> {
    Err(CmdError::Usage(
        "this nerf binary was built without the browser viewer (the wasm32-unknown-unknown target was not \
         installed): run `rustup target add wasm32-unknown-unknown`, then `cargo build --release` (or `cargo install \
         --path .`) again; the build notices the new target"
            .into(),
    ))
}

/// Runs `nerf web`.
pub fn run(a: Args) -> CmdResult {
    let wasm = module()?;
    // the model read before the folder is made: a damaged model leaves nothing behind
    let bytes = read_model(&a.model)?;
    let m = decode(&a.model, &bytes)?;
    let _out = super::outdir::OutDir::claim(&a.out, "--out", "web", super::outdir::Earlier::Replace, a.force)?;
    let o = Orbit::of(&m);
    let cam = o
        .camera(0.0, CHECK_SIZE, CHECK_SIZE)
        .map_err(|e| CmdError::File { path: a.model.clone(), reason: format!("the model's orbit: {e}") })?;
    // fx fy cx cy, then [R | t] row by row
    let r = cam.rotation.transpose();
    let mut values = vec![cam.fx, cam.fy, cam.cx, cam.cy];
    for (row, t) in [r.x_axis, r.y_axis, r.z_axis].into_iter().zip(cam.position.to_array()) {
        values.extend([row.x, row.y, row.z, t]);
    }
    let view = serde_json::json!({
        "scheme": format!("{:?}", m.scheme()),
        "orbit": o,
        "check": {
            "width": CHECK_SIZE,
            "height": CHECK_SIZE,
            // f32 bit patterns: the browser gets exactly the host's camera
            "camera_bits": values.iter().map(|v| v.to_bits()).collect::<Vec<u32>>(),
        },
    });
    create_dir(&a.out)?;
    write_atomic(&a.out.join("model.nerf"), &bytes)?;
    write_atomic(&a.out.join("nerf_web.wasm"), wasm)?;
    write_atomic(&a.out.join("view.json"), view.to_string().as_bytes())?;
    write_atomic(&a.out.join("index.html"), PAGE.as_bytes())?;
    eprintln!(
        "wrote {}: serve the folder (e.g. `python3 -m http.server -d {}`) and open index.html",
        a.out.display(),
        a.out.display()
    );
    Ok(())
}
