//! `nerf scene`: writes the built-in scene as datasets.

use super::{num_in, CmdError, CmdResult};
use nerf_train::dataset::synthetic::{write_blender, write_colmap, write_llff, write_llff_room, ColmapText, SceneSpec};
use std::path::PathBuf;

/// Arguments of `nerf scene`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directory; gets `blender/`, `llff/`, `colmap/` (binary model, JPEG, two cameras, one with
    /// lens distortion), `colmap_text/` (the same as text), `room/` (COLMAP, the scene inside a coloured
    /// room: a 360° capture with a background) and `room_llff/` (a room capture in LLFF's layout).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Replace what nerf wrote in the output folder before (another command's outputs, as its
    /// `.nerf-outputs` record lists them); files nerf did not write are never removed.
    #[arg(long)]
    pub(crate) force: bool,
    /// Image side in pixels.
    #[arg(long, default_value_t = 64, value_name = "8..=2048", value_parser = num_in(8u32, 2048))]
    pub(crate) size: u32,
    /// Training views.
    #[arg(long, default_value_t = 48, value_name = "1..=1000", value_parser = num_in(1usize, 1000))]
    pub(crate) train: usize,
}

impl Args {
    /// `nerf scene --out OUT` with every other flag at its default.
    pub fn new(out: PathBuf) -> Self {
        Self { out, force: false, size: 64, train: 48 }
    }
}

/// Runs `nerf scene`.
pub fn run(a: Args) -> CmdResult {
    let _out = super::outdir::OutDir::claim(&a.out, "--out", "scene", super::outdir::Earlier::Replace, a.force)?;
    let spec = SceneSpec { size: a.size, train: a.train, ..SceneSpec::default() };
    // stopped between captures: the folder's record names what was written, which the same command replaces
    let _stopping = super::interrupt::catch_while();
    type Write = fn(&std::path::Path, SceneSpec) -> Result<(), nerf_train::dataset::DataError>;
    let captures: [(&str, Write); 6] = [
        ("blender", write_blender),
        ("llff", write_llff),
        ("colmap", |d, s| write_colmap(d, s, ColmapText::Binary, false)),
        ("colmap_text", |d, s| write_colmap(d, s, ColmapText::Text, false)),
        ("room", |d, s| write_colmap(d, s, ColmapText::Binary, true)),
        ("room_llff", write_llff_room),
    ];
    for (k, (name, write)) in captures.iter().enumerate() {
        if super::interrupt::received() {
            return Err(CmdError::Interrupted(format!(
                "interrupted after {k} of 6 captures; the same command replaces them"
            )));
        }
        write(&a.out.join(name), spec)?;
    }
    eprintln!("wrote {} (blender/, llff/, colmap/, colmap_text/, room/, room_llff/)", a.out.display());
    Ok(())
}
