//! `nerf scene`: writes the built-in scene as datasets.

use super::CmdResult;
use nerf_train::dataset::synthetic::{write_blender, write_llff, SceneSpec};
use std::path::PathBuf;

/// Arguments of `nerf scene`.
#[derive(clap::Args)]
pub struct Args {
    /// Output directory; gets `blender/` and `llff/` datasets.
    #[arg(long)]
    out: PathBuf,
    /// Image side in pixels.
    #[arg(long, default_value_t = 64)]
    size: u32,
    /// Training views.
    #[arg(long, default_value_t = 48)]
    train: usize,
}

/// Runs `nerf scene`.
pub fn run(a: Args) -> CmdResult {
    let spec = SceneSpec { size: a.size, train: a.train, ..SceneSpec::default() };
    write_blender(&a.out.join("blender"), spec).map_err(|e| e.to_string())?;
    write_llff(&a.out.join("llff"), spec).map_err(|e| e.to_string())?;
    eprintln!("wrote {} (blender/ and llff/)", a.out.display());
    Ok(())
}
