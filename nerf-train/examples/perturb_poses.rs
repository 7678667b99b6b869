//! Writes a COLMAP capture in LLFF's layout (as `colmap_to_llff` does)
//! with the training photos' poses a little off: each photo that is not
//! held out (every `HOLDOUT`-th, 8 unless given, as `nerf train` holds them
//! out) is turned about its centre by a random rotation vector whose
//! components are normal with standard deviation `DEGREES`, and moved by a
//! random shift whose components are normal with standard deviation
//! `SHIFT` times the median distance of the cameras from their mean
//! position. Held-out photos keep their poses, so that `nerf eval` scores
//! a run against the true ones. For measuring pose refinement
//! (`per_photo.pose_refine`) on a capture whose poses are known to be off.
//!
//! ```sh
//! cargo run --release -p nerf-train --example perturb_poses -- ../shared/data/bird /tmp/bird_off 0.5 0.01
//! echo '{"pose_refine": true}' > /tmp/pose.json
//! nerf train --data /tmp/bird_off --downscale 8 --iters 2000 --config /tmp/pose.json --out /tmp/bird_off_run
//! ```
//!
//! `OUT` must not exist. Unix only (symbolic links). Seeded: the same
//! arguments write the same poses.

use glam::{DMat3, DVec3};
use nerf_train::dataset::colmap::colmap_views;
use nerf_train::dataset::reconstructions::choose_model;
use nerf_train::dataset::write_poses_bounds;
use nerf_train::util::rng::Rng;
use std::path::PathBuf;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: perturb_poses COLMAP_DIR OUT_DIR DEGREES SHIFT [HOLDOUT]";
    let (src, out, degrees, shift, holdout) = match args.as_slice() {
        [s, o, d, t] => (s, o, d, t, "8"),
        [s, o, d, t, h] => (s, o, d, t, h.as_str()),
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    };
    let number = |v: &str, what: &str| -> f64 {
        v.parse::<f64>().ok().filter(|x| x.is_finite() && *x >= 0.0).unwrap_or_else(|| {
            eprintln!("error: {what} '{v}' is not a number at least 0\n{usage}");
            std::process::exit(2)
        })
    };
    let (degrees, shift, holdout) = (number(degrees, "DEGREES"), number(shift, "SHIFT"), number(holdout, "HOLDOUT"));
    if let Err(e) = run(src.into(), out.into(), degrees, shift, (holdout as usize).max(1)) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

/// A standard normal number (Box–Muller).
fn normal(rng: &mut Rng) -> f64 {
    let (u, v) = (1.0 - rng.f32() as f64, rng.f32() as f64);
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

fn run(src: PathBuf, out: PathBuf, degrees: f64, shift: f64, holdout: usize) -> Result<(), Box<dyn std::error::Error>> {
    if out.exists() {
        return Err(format!("{}: already exists; name a new folder", out.display()).into());
    }
    let (model_dir, _) = choose_model(&src, None)?;
    let (mut views, points) = colmap_views(&src, &model_dir)?;
    let centre = views.iter().map(|v| v.pose.1).sum::<DVec3>() / views.len().max(1) as f64;
    let mut dist: Vec<f64> = views.iter().map(|v| v.pose.1.distance(centre)).collect();
    dist.sort_by(f64::total_cmp);
    let scale = shift * dist.get(dist.len() / 2).copied().unwrap_or(0.0);
    let mut rng = Rng::new(0x5E_ED0F_F5E7);
    let (mut turned, mut moved) = (0.0f64, 0.0f64);
    let mut changed = 0;
    for (i, v) in views.iter_mut().enumerate() {
        if i % holdout == 0 {
            continue;
        }
        let w = DVec3::new(normal(&mut rng), normal(&mut rng), normal(&mut rng)) * degrees.to_radians();
        let t = DVec3::new(normal(&mut rng), normal(&mut rng), normal(&mut rng)) * scale;
        let turn = if w.length() > 0.0 { DMat3::from_axis_angle(w.normalize(), w.length()) } else { DMat3::IDENTITY };
        v.pose = (turn * v.pose.0, v.pose.1 + t);
        turned += w.length().to_degrees();
        moved += t.length();
        changed += 1;
    }
    let images = out.join("images");
    std::fs::create_dir_all(&images).map_err(|e| format!("{}: {e}", images.display()))?;
    for v in &views {
        let name = v.image.file_name().ok_or_else(|| format!("{}: no file name", v.image.display()))?;
        let target = std::fs::canonicalize(&v.image).map_err(|e| format!("{}: {e}", v.image.display()))?;
        std::os::unix::fs::symlink(&target, images.join(name)).map_err(|e| format!("{}: {e}", images.display()))?;
    }
    write_poses_bounds(&out, &views, &points)?;
    let n = changed.max(1) as f64;
    eprintln!(
        "wrote {}: {changed} of {} cameras turned {:.3}° and moved {:.4} capture units on average (median camera \
         distance from their mean {:.3})",
        out.join("poses_bounds.npy").display(),
        views.len(),
        turned / n,
        moved / n,
        dist.get(dist.len() / 2).copied().unwrap_or(0.0)
    );
    Ok(())
}
