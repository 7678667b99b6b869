//! `nerf export`: writes the model with 32-, 16- or 8-bit weights.

use super::{decode, read_model, write_atomic, ActBits, CmdError, CmdResult, TableBits};
use nerf_infer::Scheme;
use nerf_train::export::{quantise_with, OwnedModel, Quantisation};
use std::path::PathBuf;

/// Arguments of `nerf export`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// f32 model file (.nerf) as `nerf train` writes it.
    pub(crate) model: PathBuf,
    /// Weight bits: 32 (f32 path), 16 or 8 (integer fixed-point path).
    #[arg(long, value_enum)]
    pub bits: Scheme,
    /// Hidden-activation bits of the integer path: 16, or 8 with `--bits 8`
    /// (ReLU outputs u8, the feature layer i8; the encoding stays 16-bit).
    #[arg(long, value_enum, default_value_t = ActBits::A16)]
    pub act_bits: ActBits,
    /// Bits per value of the feature table in an integer model: 16 (i16
    /// values), or 8 or 4: indices into a codebook of 256 or 16 i16 values
    /// per level, fitted to the values the occupied cells read (Lloyd–Max;
    /// format version 7). About 2× or 4× fewer table bytes, each value
    /// moved to its nearest code (measure the PSNR and the time per ray
    /// with `nerf eval`).
    #[arg(long, value_enum, default_value_t = TableBits::T16)]
    pub table_bits: TableBits,
    /// Coarsen the occupancy grid to this many cells per axis (a divisor of
    /// the model's): 8× fewer grid bytes per halving, a little more empty
    /// space sampled, nothing occupied lost.
    #[arg(long)]
    pub(crate) grid_res: Option<u16>,
    /// With `--bits 16`: round these layers' weights to the int8 export's
    /// precision (comma-separated indices in file order: trunk layers,
    /// density head, then the feature, view and colour layers; `nerf info
    /// --json` lists them), to find which layers 8-bit weights cost PSNR.
    /// The int8 export keeps the view layer's direction rows and the colour
    /// and density heads at 16 bits, and so does this (listing the density
    /// head leaves it at 16 bits). Listing every layer renders exactly as
    /// `--bits 8` does.
    #[arg(long, value_delimiter = ',')]
    pub(crate) int8_layers: Vec<usize>,
    /// Set the model's default stratified samples per ray (2..=1024, at
    /// most 256 with a fine network; what a renderer uses unless told
    /// otherwise): fewer samples, less time per ray, some PSNR (measure
    /// with `nerf eval --coarse`).
    #[arg(long, value_name = "2..=1024", value_parser = clap::value_parser!(u16).range(2..=1024))]
    pub(crate) coarse: Option<u16>,
    /// Set the model's default network samples per ray after the coarse
    /// pass: with a proposal grid, the samples drawn from its weights
    /// (1..=255); with a fine network, its importance samples (1..=256).
    /// Fewer samples, less time per ray, some PSNR (measure with `nerf eval
    /// --fine`; docs/RESULTS.md has the curve for bird, fox and the room).
    #[arg(long, value_name = "1..=256", value_parser = clap::value_parser!(u16).range(1..=256))]
    pub(crate) fine: Option<u16>,
    /// Output file.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Replace the model file already at --out (never another kind of file, nor a training checkpoint).
    #[arg(long)]
    pub(crate) force: bool,
}

/// An existing `--out` is replaced only if it is a model file (starts with
/// the `NERF` magic) and `--force` is given: a photo or any other file of
/// the user's is kept, and so is a training checkpoint (`NERFCKPT`: a run
/// that could no longer resume), with or without `--force`.
fn refuse_existing(out: &std::path::Path, force: bool) -> CmdResult {
    use std::io::Read;
    // only a regular file is opened (a FIFO would block); the atomic write refuses the rest
    let regular = std::fs::symlink_metadata(out).is_ok_and(|m| m.is_file());
    if let Some(mut f) = regular.then(|| std::fs::File::open(out).ok()).flatten() {
        let mut magic = [0u8; 8];
        let n = f.read(&mut magic).unwrap_or(0);
        let refused = |reason: String| Err(CmdError::Flag { flag: "--out", reason });
        if n == 8 && magic == nerf_infer::format::CHECKPOINT_MAGIC {
            return refused(format!(
                "{}: is a training checkpoint (a run resumes from it); a model never replaces one: choose another \
                 file",
                out.display()
            ));
        }
        if !(n >= 4 && &magic[..4] == b"NERF") {
            return refused(format!("{}: exists and is not a model file; refusing to replace it", out.display()));
        }
        if !force {
            return refused(format!(
                "{}: holds a model already; replace it with --force, or choose another file",
                out.display()
            ));
        }
    }
    Ok(())
}

impl Args {
    /// `nerf export MODEL --bits BITS --out OUT` with every other flag at its default.
    pub fn new(model: PathBuf, bits: Scheme, out: PathBuf) -> Self {
        Self {
            model,
            bits,
            act_bits: ActBits::A16,
            table_bits: TableBits::T16,
            grid_res: None,
            int8_layers: Vec::new(),
            coarse: None,
            fine: None,
            out,
            force: false,
        }
    }
}

/// Runs `nerf export`.
pub fn run(a: Args) -> CmdResult {
    if a.act_bits == ActBits::A8 && a.bits != Scheme::I8 {
        return Err(CmdError::Flag {
            flag: "--act-bits",
            reason: "8 needs --bits 8 (8-bit activations are an int8-weight scheme)".into(),
        });
    }
    if a.table_bits != TableBits::T16 {
        // the scheme asked for, before the model is read: narrow_table checks the model's again
        nerf_train::export::narrow_table_fits(a.bits, a.table_bits.bits()).map_err(|_| CmdError::Flag {
            flag: "--table-bits",
            reason: format!("{} needs --bits 16 or 8 (an f32 model keeps an f32 table)", a.table_bits.bits()),
        })?;
    }
    if !a.int8_layers.is_empty() && a.bits != Scheme::I16 {
        return Err(CmdError::Flag {
            flag: "--int8-layers",
            reason: "needs --bits 16 (it narrows layers of an int16 model)".into(),
        });
    }
    super::refuse_same_file(&a.out, "--out", &a.model)?;
    refuse_existing(&a.out, a.force)?;
    let bytes = read_model(&a.model)?;
    let model = decode(&a.model, &bytes)?;
    let refused = |reason: String| Err(CmdError::File { path: a.model.clone(), reason });
    let mut owned = match a.bits {
        Scheme::F32 if model.scheme() == Scheme::F32 => OwnedModel::from_model(&model),
        Scheme::F32 => return refused("model is already quantised; export from the f32 model".into()),
        scheme => {
            let act_bits = a.act_bits;
            let layers = model.coarse.layers.len();
            if let Some(&bad) = a.int8_layers.iter().find(|&&i| i >= layers) {
                return refused(format!("--int8-layers {bad}: the network has layers 0 to {}", layers - 1));
            }
            quantise_with(
                &model,
                &Quantisation {
                    eight_bit_layers: a.int8_layers.clone(),
                    ..Quantisation::new(scheme).with_act_bits(act_bits)
                },
            )
            .map_err(CmdError::file(&a.model))?
        }
    };
    if a.table_bits != TableBits::T16 {
        nerf_train::export::narrow_table(&mut owned, a.table_bits.bits()).map_err(|e| CmdError::File {
            path: a.model.clone(),
            reason: format!("--table-bits {}: {e}", a.table_bits.bits()),
        })?;
    }
    if let Some(r) = a.grid_res {
        nerf_train::export::coarsen_grid(&mut owned, r).map_err(CmdError::file(&a.model))?;
    }
    if let Some(n) = a.coarse {
        owned.samples.coarse = n;
    }
    if let Some(n) = a.fine {
        if owned.fine.is_none() && owned.proposal.is_none() {
            return refused(format!(
                "--fine {n}: the model has neither a fine network nor a proposal grid (set --coarse)"
            ));
        }
        if owned.proposal.is_some() && n > 255 {
            return refused(format!("--fine {n}: a model with a proposal grid takes 1..=255"));
        }
        owned.samples.fine = n;
    }
    let out = owned.to_bytes().map_err(CmdError::file(&a.out))?;
    write_atomic(&a.out, &out)?;
    let acts = match a.bits {
        Scheme::F32 => String::new(),
        _ => format!(", {}-bit activations", a.act_bits.bits()),
    };
    let table = match a.table_bits {
        TableBits::T16 => String::new(),
        t => format!(", {}-bit feature table", t.bits()),
    };
    eprintln!("wrote {} ({} bytes, {}-bit weights{acts}{table})", a.out.display(), out.len(), a.bits.bits());
    Ok(())
}
