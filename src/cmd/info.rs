//! `nerf info`: what a model file holds.

use super::{decode, read_model, CmdResult};
use std::path::PathBuf;

/// Arguments of `nerf info`.
#[derive(clap::Args)]
pub struct Args {
    /// Model file (.nerf).
    model: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// Runs `nerf info`.
pub fn run(a: Args) -> CmdResult {
    let bytes = read_model(&a.model)?;
    let m = decode(&a.model, &bytes)?;
    let net = |n: &nerf_infer::format::Network<'_>| {
        serde_json::json!({
            "scheme": format!("{:?}", n.scheme),
            "activation_bits": n.act_bits,
            "layers": n.layers.iter().map(|l| serde_json::json!({
                "in": l.in_dim, "out": l.out_dim, "act_max": l.act_max,
                "bytes": l.weights.len() + l.bias.len() + l.scales.len() + l.requant.len(),
            })).collect::<Vec<_>>(),
            "parameters": n.layers.iter().map(|l| (l.in_dim as usize + 1) * l.out_dim as usize).sum::<usize>(),
        })
    };
    let info = serde_json::json!({
        "file": a.model.display().to_string(),
        "file_bytes": bytes.len(),
        "tensor_bytes": m.tensor_bytes(),
        "unpruned_tensor_bytes": m.unpruned_tensor_bytes(),
        "pruned": m.is_pruned(),
        "format_version": m.format_version(),
        "grid": m.grid.map(|g| serde_json::json!({
            "res": g.res, "occupied_cells": g.occupied_cells(), "bytes": g.bits.len(),
        })),
        "features": m.features.as_ref().map(|f| serde_json::json!({
            "levels": f.levels(), "width": f.width, "log2_table": f.log2_table, "frac_bits": f.frac_bits,
            "resolutions": f.resolutions.as_slice(), "bytes": f.table.len(),
            "value_bits": f.narrow.map_or(if m.scheme().is_fixed() { 16 } else { 32 }, |n| n.bits),
            "codebook_bytes": f.narrow.map_or(0, |n| n.codebook.len()),
        })),
        "scheme": format!("{:?}", m.scheme()),
        "scene": { "bounds_min": m.scene.bounds_min, "bounds_max": m.scene.bounds_max, "near": m.scene.near, "far": m.scene.far,
                   "white_background": m.scene.white_background, "ndc": m.scene.ndc.is_some(),
                   "unbounded": m.scene.unbounded.map(|u| serde_json::json!({ "linear_until": u.linear_until })) },
        "encoding": { "pos_freqs": m.encoding.pos_freqs, "dir_freqs": m.encoding.dir_freqs, "include_input": m.encoding.include_input, "raw_frac_bits": m.encoding.raw_frac_bits },
        "topology": { "depth": m.topology.depth, "width": m.topology.width, "skips": (1..16).filter(|&i| m.topology.is_skip(i)).collect::<Vec<_>>(),
                      "view_dependent": m.topology.view_dependent, "view_width": m.topology.view_width },
        "samples": { "coarse": m.samples.coarse, "fine": m.samples.fine },
        "trained": { "downscale": m.meta.train_downscale, "iterations": m.meta.iterations },
        "capture": m.capture.map(|c| serde_json::json!({
            "holdout": c.holdout, "views": c.views, "held_out_crc": c.held_out_crc,
            "framing": format!("{:?}", c.framing), "lens": c.lens,
        })),
        "orbit": m.orbit,
        "footprint": m.footprint.map(|f| serde_json::json!({ "pixel": f.pixel })),
        "proposal": m.proposal.map(|p| serde_json::json!({
            "res": p.res,
            "bytes": p.codes.len(),
            "occupied_cells": p.codes.iter().filter(|&&c| c > 0).count(),
            "sigma_max": p.sigma_of(255),
        })),
        "coarse": net(&m.coarse),
        "fine": m.fine.as_ref().map(net),
        "precise": m.coarse.precise.map(|p| serde_json::json!({
            "view_dirs_bytes": p.view_dirs.len(), "colour_head": p.colour.is_some(),
            "density_head": p.density.is_some(),
            "bytes": p.bytes() + m.fine.as_ref().and_then(|f| f.precise).map_or(0, |p| p.bytes()),
        })),
    });
    if a.json {
        println!("{info}");
        return Ok(());
    }
    let t = &m.topology;
    let skips: Vec<usize> = (1..16).filter(|&i| t.is_skip(i)).collect();
    println!(
        "{}: NeRF model, format version {}, {} bytes ({} in tensors)",
        a.model.display(),
        m.format_version(),
        bytes.len(),
        m.tensor_bytes()
    );
    println!("  numeric scheme: {:?} weights, {}-bit activations", m.scheme(), m.coarse.act_bits);
    println!(
        "  network: {}x{} trunk, skips {:?}, view branch {}",
        t.depth,
        t.width,
        skips,
        if t.view_dependent { format!("on ({} wide)", t.view_width) } else { "off".into() }
    );
    println!(
        "  encoding: L = {} (position), {} (direction), raw input {}",
        m.encoding.pos_freqs,
        m.encoding.dir_freqs,
        if m.encoding.include_input { "included" } else { "excluded" }
    );
    println!(
        "  samples: {} coarse + {} fine; fine network {}",
        m.samples.coarse,
        m.samples.fine,
        if m.fine.is_some() { "present" } else { "absent" }
    );
    println!(
        "  scene: bounds {:?}..{:?}, near {}, far {}, {} background{}",
        m.scene.bounds_min,
        m.scene.bounds_max,
        m.scene.near,
        m.scene.far,
        if m.scene.white_background { "white" } else { "black" },
        match (m.scene.ndc, m.scene.unbounded) {
            (Some(_), _) => ", NDC rays".to_string(),
            (_, Some(u)) => format!(
                ", unbounded (space beyond the bounds contracted; samples even in t up to {}, then in 1/t)",
                u.linear_until
            ),
            _ => String::new(),
        }
    );
    match m.grid {
        Some(g) => {
            let cells = (g.res as usize).pow(3);
            let occ = g.occupied_cells();
            println!(
                "  occupancy grid: {r}x{r}x{r}, {occ} of {cells} cells occupied ({:.1} %), {} bytes",
                100.0 * occ as f64 / cells as f64,
                g.bits.len(),
                r = g.res
            );
        }
        None => println!("  occupancy grid: none (every sample is evaluated)"),
    }
    if let Some(f) = &m.features {
        let r = f.resolutions.as_slice();
        println!(
            "  feature grid: {} levels x {} values, {}..{} cells per axis, 2^{} entries per level, {} bytes{}",
            f.levels(),
            f.width,
            r[0],
            r[r.len() - 1],
            f.log2_table,
            f.table.len(),
            match f.narrow {
                Some(n) => format!(
                    " ({}-bit indices into a codebook of {} i16 values per level, Q{}, {} bytes)",
                    n.bits,
                    1 << n.bits,
                    f.frac_bits,
                    n.codebook.len()
                ),
                None if m.scheme().is_fixed() => format!(" (i16, Q{})", f.frac_bits),
                None => String::new(),
            }
        );
    }
    if let Some(f) = m.footprint {
        println!(
            "  footprint: features averaged over {} points across each sample's pixel ({:.3} mrad per training pixel)",
            nerf_infer::camera::FOOTPRINT_POINTS,
            1e3 * f.pixel
        );
    }
    if let Some(p) = m.proposal {
        let occupied = p.codes.iter().filter(|&&c| c > 0).count();
        println!(
            "  proposal grid: {}³ density codes ({} B, {:.1} % of cells not empty) place the network's {} samples per \
             ray among {} stratified ones",
            p.res,
            p.codes.len(),
            100.0 * occupied as f64 / p.codes.len().max(1) as f64,
            m.samples.fine,
            m.samples.coarse
        );
    }
    println!("  trained: {} iterations at downscale {}", m.meta.iterations, m.meta.train_downscale);
    if let Some(c) = m.capture {
        println!(
            "  capture: {} views, every {}-th held out (eval and render reuse it), scene {:?}, lens {}",
            c.views,
            c.holdout,
            c.framing,
            if c.lens { "applied" } else { "ignored" }
        );
    }
    if let Some(o) = m.orbit {
        let v = |v: [f32; 3]| format!("({:.3}, {:.3}, {:.3})", v[0], v[1], v[2]);
        println!(
            "  orbit (fitted to the training cameras): around {} with up {}, radius {:.3}, height {:.3}, {:.1}° across, \
             from azimuth {:.1}°",
            v(o.centre),
            v(o.up),
            o.radius,
            o.height,
            o.fov_x.to_degrees(),
            o.azimuth.to_degrees()
        );
    }
    if let Some(p) = m.coarse.precise {
        let parts: Vec<&str> = [
            (!p.view_dirs.is_empty()).then_some("the view layer's direction rows"),
            p.colour.map(|_| "the colour head"),
            p.density.map(|_| "the density head"),
        ]
        .into_iter()
        .flatten()
        .collect();
        println!("  at 16 bits: {} ({} bytes)", parts.join(", "), info["precise"]["bytes"]);
    }
    println!("  parameters: {} per network", info["coarse"]["parameters"]);
    println!("  pruning: {}", pruning(&m));
    Ok(())
}

/// One line on pruning: the kept widths of the prunable layers and the
/// tensor bytes before and after.
fn pruning(m: &nerf_infer::Model<'_>) -> String {
    let (after, before) = (m.tensor_bytes(), m.unpruned_tensor_bytes());
    if !m.is_pruned() {
        return format!("none (every neuron kept; {after} tensor bytes)");
    }
    let t = &m.topology;
    let widths = |n: &nerf_infer::format::Network<'_>| {
        let w: Vec<String> = (0..n.layers.len())
            .filter(|&i| nerf_infer::format::prunable(t, i))
            .map(|i| n.layers[i].out_dim.to_string())
            .collect();
        w.join("/")
    };
    let nets = match &m.fine {
        Some(f) => format!("coarse {}, fine {}", widths(&m.coarse), widths(f)),
        None => widths(&m.coarse),
    };
    format!(
        "kept widths {nets} (of {}{}); tensor bytes {before} before, {after} after ({:.1} % fewer)",
        t.width,
        if t.view_dependent { format!(", view {}", t.view_width) } else { String::new() },
        100.0 * (before - after) as f64 / before as f64
    )
}
