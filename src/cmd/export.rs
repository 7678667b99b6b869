//! `nerf export`: writes the model with 32-, 16- or 8-bit weights.

use super::{decode, read_model, write_atomic, CmdResult};
use nerf_infer::Scheme;
use nerf_train::export::{quantise, OwnedModel};
use std::path::PathBuf;

/// Arguments of `nerf export`.
#[derive(clap::Args)]
pub struct Args {
    /// f32 model file (.nerf) as `nerf train` writes it.
    model: PathBuf,
    /// Weight bits: 32 (f32 path), 16 or 8 (integer fixed-point path).
    #[arg(long, value_parser = ["32", "16", "8"])]
    bits: String,
    /// Output file.
    #[arg(long)]
    out: PathBuf,
}

/// Runs `nerf export`.
pub fn run(a: Args) -> CmdResult {
    let bytes = read_model(&a.model)?;
    let model = decode(&a.model, &bytes)?;
    let owned = match a.bits.as_str() {
        "32" if model.scheme() == Scheme::F32 => OwnedModel::from_model(&model),
        "32" => return Err(format!("{}: model is already quantised; export from the f32 model", a.model.display())),
        "16" => quantise(&model, Scheme::I16).map_err(|e| format!("{}: {e}", a.model.display()))?,
        _ => quantise(&model, Scheme::I8).map_err(|e| format!("{}: {e}", a.model.display()))?,
    };
    let out = owned.to_bytes().map_err(|e| format!("{}: {e}", a.out.display()))?;
    write_atomic(&a.out, &out)?;
    eprintln!("wrote {} ({} bytes, {}-bit weights)", a.out.display(), out.len(), a.bits);
    Ok(())
}
