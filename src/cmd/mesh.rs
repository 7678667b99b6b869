//! `nerf mesh`: the model's density surface as a triangle mesh (PLY or
//! OBJ) with vertex colours, its area, volume and closure, and optionally
//! the agreement of its silhouette with a capture's alpha masks.

use super::{decode, load_split, num_in, progress, read_model, refuse_same_file, with_threads, write_atomic};
use super::{CaptureArgs, CmdError, CmdResult, Split};
use nerf_train::dataset::load_rgba;
use nerf_train::mesh::silhouette::{iou, silhouette};
use nerf_train::mesh::{extract, sample_density, write, Mesh, MeshOptions, MeshStats};
use std::path::{Path, PathBuf};

/// Arguments of `nerf mesh`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model file (.nerf): f32, int16 or int8 (the mesh follows the network the renderer runs).
    pub(crate) model: PathBuf,
    /// Output mesh: `.ply` (binary) or `.obj` (text), by extension; an existing file only with --force.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Replace the file already at --out.
    #[arg(long)]
    pub(crate) force: bool,
    /// Lattice cells per axis over the scene's bounds; memory grows as its cube (256: 68 MB).
    #[arg(long, default_value_t = 256, value_name = "2..=1024", value_parser = num_in(2usize, 1024))]
    pub(crate) resolution: usize,
    /// Density of the surface, per world unit (a ray crossing d world units of it loses 1 − exp(−σ·d) of its
    /// light).
    #[arg(long, default_value_t = 25.0, value_name = "σ > 0")]
    pub(crate) threshold: f32,
    /// Keep only the connected pieces with at least this fraction of the largest piece's triangles (0 keeps
    /// everything, 1 the largest piece): drops density the training left floating in empty space.
    #[arg(long, default_value_t = 0.1, value_name = "0..=1", value_parser = num_in(0.0f64, 1.0))]
    pub(crate) min_piece: f64,
    /// No vertex colours (faster; the model's colour branch is not run).
    #[arg(long)]
    pub(crate) no_colours: bool,
    /// Compare the mesh's silhouette with the alpha masks of this capture's views (RGBA images: Blender
    /// layout): prints the intersection over union per view and its mean.
    #[arg(long, value_name = "DATA")]
    pub(crate) masks: Option<PathBuf>,
    /// The split of --masks to compare with.
    #[arg(long, value_enum, default_value_t = Split::Test, requires = "masks")]
    pub(crate) split: Split,
    #[command(flatten)]
    pub(crate) capture: CaptureArgs,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0, value_name = "0..=1024", value_parser = num_in(0usize, 1024))]
    pub(crate) threads: usize,
}

/// What `nerf mesh` prints (one JSON object).
#[derive(serde::Serialize)]
struct Report {
    mesh: PathBuf,
    resolution: usize,
    threshold: f32,
    min_piece: f64,
    #[serde(flatten)]
    stats: MeshStats,
    closed: bool,
    pieces_dropped: usize,
    silhouette_iou: Option<f64>,
    silhouette_iou_per_view: Option<Vec<f64>>,
}

enum Kind {
    Ply,
    Obj,
}

fn kind(out: &Path) -> CmdResult<Kind> {
    match out.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("ply") => Ok(Kind::Ply),
        Some("obj") => Ok(Kind::Obj),
        _ => Err(CmdError::Flag {
            flag: "--out",
            reason: format!("{}: the file name must end in .ply or .obj", out.display()),
        }),
    }
}

/// Runs `nerf mesh`.
pub fn run(a: Args) -> CmdResult {
    let kind = kind(&a.out)?;
    refuse_same_file(&a.out, "--out", &a.model)?;
    if !(a.threshold.is_finite() && a.threshold > 0.0) {
        return Err(CmdError::Flag {
            flag: "--threshold",
            reason: format!("{}: must be a positive density", a.threshold),
        });
    }
    let out_refused = |reason: String| Err(CmdError::Flag { flag: "--out", reason });
    match std::fs::symlink_metadata(&a.out) {
        Ok(m) if m.is_dir() => {
            return out_refused(format!("{}: is a folder; give a file ending in .ply or .obj", a.out.display()))
        }
        Ok(_) if !a.force => {
            return out_refused(format!("{}: exists; replace it with --force, or choose another file", a.out.display()))
        }
        _ => {}
    }
    let bytes = read_model(&a.model)?;
    let m = decode(&a.model, &bytes)?;
    // the masks first: a capture that cannot be compared with fails before anything is extracted or written
    let masks = match &a.masks {
        Some(dir) => Some(with_threads(a.threads, || masks(dir, &a, &m))??),
        None => None,
    };
    let opts = MeshOptions { resolution: a.resolution, threshold: a.threshold, colours: !a.no_colours };
    let (mesh, dropped) = with_threads(a.threads, || -> CmdResult<(Mesh, usize)> {
        let pb = progress(a.resolution as u64 + 1, "density {bar:40} {pos}/{len} planes {elapsed}/{eta}");
        let density = sample_density(&m, a.resolution, &|_| pb.inc(1));
        pb.finish_and_clear();
        // no surface: nothing to write, and an empty mesh is not a closed one
        let peak = density.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        if peak.is_nan() || peak < a.threshold {
            return Err(CmdError::File {
                path: a.model.clone(),
                reason: format!(
                    "no surface at --threshold {}: the density sampled on the {}³ grid peaks at {}; give a lower \
                     --threshold",
                    a.threshold,
                    a.resolution,
                    nerf_train::error::number(peak as f64)
                ),
            });
        }
        eprintln!("extracting the surface{}", if opts.colours { " and its colours" } else { "" });
        let mut mesh = extract(&m, &density, opts).map_err(CmdError::file(&a.model))?;
        let dropped = mesh.drop_small_pieces(a.min_piece);
        Ok((mesh, dropped))
    })??;
    let stats = mesh.stats();
    let file = match kind {
        Kind::Ply => write::ply(&mesh),
        Kind::Obj => write::obj(&mesh),
    };
    write_atomic(&a.out, &file)?;
    let per_view: Option<Vec<f64>> =
        masks.map(|ms| ms.iter().map(|(cam, mask)| iou(&silhouette(&mesh, cam), mask)).collect());
    let report = Report {
        mesh: a.out.clone(),
        resolution: a.resolution,
        threshold: a.threshold,
        min_piece: a.min_piece,
        stats,
        closed: stats.triangles > 0 && stats.open_edges == 0,
        pieces_dropped: dropped,
        silhouette_iou: per_view.as_ref().map(|v| v.iter().sum::<f64>() / v.len().max(1) as f64),
        silhouette_iou_per_view: per_view,
    };
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}

/// The camera and alpha mask (alpha > ½) of each view of `--masks`, to
/// compare the mesh's silhouette with.
fn masks(dir: &Path, a: &Args, m: &nerf_infer::Model<'_>) -> CmdResult<Vec<(nerf_infer::Camera, Vec<bool>)>> {
    use rayon::prelude::*;
    let capture = a.capture.for_model(m, &a.model)?;
    let data = load_split(dir, a.split, capture.downscale_for(m), capture)?;
    super::same_frame(&data, m, &a.model)?;
    data.views
        .par_iter()
        .map(|v| {
            let (w, h, _, alpha) = load_rgba(&v.file, data.downscale, false)?;
            let refused = |reason: String| CmdError::File { path: v.file.clone(), reason };
            // an opaque photo has no mask: its IoU would say nothing
            let alpha = alpha.ok_or_else(|| {
                refused(format!(
                    "--masks {}: the photo has no alpha channel; give a capture whose photos are masked (RGBA, as \
                     Blender renders them)",
                    dir.display()
                ))
            })?;
            if (w, h) != (v.camera.width, v.camera.height) {
                return Err(refused(format!("alpha mask {w}x{h} but camera {}x{}", v.camera.width, v.camera.height)));
            }
            Ok((v.camera, alpha.iter().map(|&x| x > 0.5).collect()))
        })
        .collect()
}
