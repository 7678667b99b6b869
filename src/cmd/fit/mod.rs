//! `nerf fit`: sizes the model to the scene. Trains candidate
//! configurations in order of cost (multiply-accumulates per sample, plus
//! the feature grid's lookups in MAC-equivalents; all with the occupancy
//! grid), quantises each to the fixed-point path and scores it on the
//! validation views. A candidate that reaches the target PSNR is rendered
//! again with fewer samples per ray while it still reaches it. Candidates
//! are trained until even a third of the next one's samples would cost
//! more per ray than the cheapest found; of those that reached the target,
//! the one with the fewest µs per ray (fixed point, one core) is kept, with
//! its fewest samples as the model's default. Writes the table of what it
//! tried.
//!
//! With `--max-bytes`, a device's flash budget: each candidate is first
//! made to fit it (its model file's size is known before training: a
//! model with random weights of the same shape is exported): the feature
//! table halved down to 2¹⁰ entries per level, the occupancy grid
//! coarsened down to 32³, then both further, as far as needed; a
//! candidate that cannot fit is skipped. Without `--target-psnr` the most
//! accurate candidate that fits is kept; with it, the fastest that reaches
//! the target. What each candidate gave up to fit is printed and tabled.

use super::{create_dir, eval, fixed_scheme, num_in, train, write_atomic, CaptureArgs, CmdError, CmdResult};
use nerf_infer::camera::FOOTPRINT_POINTS;
use nerf_infer::Scheme;
use nerf_train::config::{Preset, TrainConfig};
use nerf_train::dataset::Split;
use nerf_train::export::{quantise, random_model, OwnedModel};
use std::path::{Path, PathBuf};

mod budget;
mod tables;
use budget::*;
use tables::*;

/// Arguments of `nerf fit`.
#[derive(clap::Args)]
pub struct Args {
    /// Dataset directory (with validation views).
    #[arg(long)]
    data: PathBuf,
    #[command(flatten)]
    capture: CaptureArgs,
    /// PSNR (dB) the fixed-point render must reach on the validation views (required without --max-bytes).
    #[arg(long, value_name = "1.0..=99.0", value_parser = num_in(1.0f64, 99.0), required_unless_present = "max_bytes")]
    target_psnr: Option<f64>,
    /// Largest fixed-point model file in bytes (a device's flash for the model): candidates are shrunk to fit
    /// or skipped; without --target-psnr the most accurate that fits is kept.
    #[arg(long, value_name = "1024..", value_parser = num_in(1024usize, usize::MAX))]
    max_bytes: Option<usize>,
    /// Training minutes per candidate.
    #[arg(long, default_value_t = 10.0, value_name = "0.001..=100000.0", value_parser = num_in(0.001f64, 100_000.0))]
    minutes: f64,
    /// Weight bits of the fixed-point model that is scored and timed.
    #[arg(long, value_name = "16|8", value_parser = fixed_scheme(), default_value = "8")]
    bits: Scheme,
    /// Early ray termination (transmittance threshold) of the scored render.
    #[arg(long, default_value_t = 1e-3, value_name = "0.0..=0.5", value_parser = num_in(0.0f32, 0.5))]
    early_stop: f32,
    /// Run directory: one sub-directory per candidate, fit.csv, fit.md and
    /// the chosen model.nerf (f32) and model_fixed.nerf.
    #[arg(long)]
    out: PathBuf,
    /// Replace an earlier fit's results in --out (or another command's outputs, as its `.nerf-outputs` record
    /// lists them); files nerf did not record writing (a training run, a user's) are never removed.
    #[arg(long)]
    force: bool,
    /// Seed of every candidate's training.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads for training (0: all cores); timing uses one.
    #[arg(long, default_value_t = 0, value_name = "0..=1024", value_parser = num_in(0usize, 1024))]
    threads: usize,
}

/// The candidates, cheapest first ([`cost`]): the presets of
/// [`Preset::FIT`], by name.
pub fn candidates() -> Vec<(&'static str, TrainConfig)> {
    let mut c: Vec<_> = Preset::FIT.iter().map(|p| (p.name(), p.config())).collect();
    c.sort_by_key(|(_, cfg)| cost(cfg));
    c
}

/// Multiply-accumulates per sample of a configuration's network.
pub fn macs(cfg: &TrainConfig) -> usize {
    cfg.mlp().macs_per_sample()
}

/// What one feature-grid level costs per sample in the int8 kernel, in
/// multiply-accumulates of its layers: on the `features` preset's lego
/// model (AVX2, 8 levels per register, run C) `perf` put the lookups
/// at 11.5 % of the render's time and the layers (15 488 MAC/sample) at
/// 47.6 %: 3 740 MAC-equivalents for 8 levels (callgrind: 61 instructions
/// per level, 0.26 per MAC; the gathers cost more than their count).
pub const FEATURE_LEVEL_MACS: usize = 500;

/// A candidate's cost per sample: [`macs`] plus its feature-grid levels
/// at [`FEATURE_LEVEL_MACS`] each, once per point read (the
/// [`FOOTPRINT_POINTS`] of a pixel footprint, else one).
pub fn cost(cfg: &TrainConfig) -> usize {
    let points = if cfg.features.footprint { FOOTPRINT_POINTS } else { 1 };
    macs(cfg) + cfg.features.levels.map_or(0, |l| l.get() as usize) * FEATURE_LEVEL_MACS * points
}

/// One tried candidate.
#[derive(Clone)]
struct Row {
    name: &'static str,
    coarse: u16,
    macs: usize,
    cost: usize,
    steps: u32,
    psnr_f32: f64,
    psnr_fixed: f64,
    us_per_ray: f64,
    samples_per_ray: f64,
    bytes: usize,
    /// What the candidate gave up to fit `--max-bytes` ("; "-separated).
    gave_up: String,
}

/// `nerf eval` of `model` on the validation views, with `coarse` samples
/// per ray, timing the fastest of `repeat` renders of each view.
fn score(a: &Args, model: &Path, threads: usize, coarse: u16, repeat: u32) -> CmdResult<eval::Report> {
    let args = eval::Args {
        split: Split::Val,
        capture: a.capture,
        threads,
        early_stop: a.early_stop,
        coarse: Some(coarse as usize),
        repeat,
        ..eval::Args::new(model.to_path_buf(), a.data.clone())
    };
    eval::evaluate(&args)
}

/// Trains candidate `name`, quantises it (`model_fixed.nerf` beside the
/// run's `model.nerf`) and scores both at the trained samples per ray.
fn try_one(a: &Args, name: &'static str, cfg: &TrainConfig) -> CmdResult<Row> {
    let dir = a.out.join(name);
    create_dir(&dir)?;
    let cfg_path = dir.join("config.json");
    write_atomic(&cfg_path, serde_json::to_string_pretty(cfg)?.as_bytes())?;
    let args = train::Args {
        capture: a.capture,
        seed: a.seed,
        threads: a.threads,
        val_views: 0,
        // the candidate's folder is fit's own (fit refuses a RUN_DIR that holds a fit)
        force: true,
        ..train::Args::new(a.data.clone(), a.minutes, dir.clone())
    };
    train::run_config(args, cfg.clone()).map_err(|e| match e {
        // a candidate's checkpoint cannot be resumed through fit
        CmdError::Interrupted(_) => CmdError::Interrupted(format!(
            "interrupted while training candidate {}: nerf fit does not resume; run it again with a new --out",
            dir.display()
        )),
        e => e,
    })?;
    let f32_path = dir.join("model.nerf");
    let bytes = super::read_model(&f32_path)?;
    let m = super::decode(&f32_path, &bytes)?;
    let scheme = a.bits;
    let q = quantise(&m, scheme).map_err(CmdError::file(&f32_path))?;
    let q = q.to_bytes().map_err(CmdError::file(&f32_path))?;
    let fixed_path = dir.join("model_fixed.nerf");
    write_atomic(&fixed_path, &q)?;
    let steps = m.meta.iterations;
    score_row(a, name, cfg, &dir, m.samples.coarse, steps, q.len())
}

/// The row of candidate `name` (run directory `dir`) rendered with `coarse`
/// samples per ray: f32 and fixed-point PSNR, the fixed path's cost.
fn score_row(
    a: &Args,
    name: &'static str,
    cfg: &TrainConfig,
    dir: &Path,
    coarse: u16,
    steps: u32,
    bytes: usize,
) -> CmdResult<Row> {
    let rf = score(a, &dir.join("model.nerf"), a.threads, coarse, 1)?;
    // the timed render: one core, the fastest of 3 per view
    let rq = score(a, &dir.join("model_fixed.nerf"), 1, coarse, 3)?;
    Ok(Row {
        name,
        coarse,
        macs: macs(cfg),
        cost: cost(cfg),
        steps,
        psnr_f32: rf.psnr,
        psnr_fixed: rq.psnr,
        us_per_ray: rq.us_per_ray,
        samples_per_ray: rq.samples_per_ray,
        bytes,
        gave_up: String::new(),
    })
}

/// Fewer samples per ray for the chosen candidate: ¾, ½ and ⅓ of the
/// trained count in turn while the fixed-point render still reaches the
/// target.
fn fewer_samples(n: u16) -> impl Iterator<Item = u16> {
    [(3, 4), (1, 2), (1, 3)].into_iter().map(move |(p, q)| (n * p / q).max(2)).filter(move |&k| k < n)
}

/// Rewrites `model` (a run's file) as `out` with `coarse` default samples per ray.
fn with_coarse(model: &Path, coarse: u16, out: &Path) -> CmdResult {
    let bytes = super::read_model(model)?;
    let mut owned = OwnedModel::from_model(&super::decode(model, &bytes)?);
    owned.samples.coarse = coarse;
    write_atomic(out, &owned.to_bytes().map_err(CmdError::file(out))?)
}

/// What a candidate's render costs per ray with `coarse` samples, in
/// cost units ([`cost`] per sample): the estimate that decides which
/// candidates are still worth training.
fn cost_per_ray(cfg: &TrainConfig, coarse: u16) -> usize {
    cost(cfg) * coarse as usize
}

/// The fewest samples per ray ([`fewer_samples`]) at which candidate `name`
/// (trained, first row `first`) still reaches the target; every render
/// tried goes into `rows`. Returns that count and its µs per ray.
fn fewest_samples(
    a: &Args,
    name: &'static str,
    cfg: &TrainConfig,
    first: &Row,
    rows: &mut Vec<Row>,
) -> CmdResult<(u16, f64)> {
    let dir = a.out.join(name);
    let mut best = (first.coarse, first.us_per_ray);
    for k in fewer_samples(first.coarse) {
        let row = Row { gave_up: first.gave_up.clone(), ..score_row(a, name, cfg, &dir, k, first.steps, first.bytes)? };
        report(a, &row);
        let reached = a.target_psnr.is_some_and(|t| row.psnr_fixed >= t);
        let us = row.us_per_ray;
        rows.push(row);
        save(a, rows)?;
        if !reached {
            break;
        }
        best = (k, us);
    }
    Ok(best)
}

fn report(a: &Args, row: &Row) {
    out!(
        "fit: {} at {} samples: int{} {:.2} dB (f32 {:.2} dB), {:.1} µs/ray, {:.1} samples/ray evaluated",
        row.name,
        row.coarse,
        a.bits.bits(),
        row.psnr_fixed,
        row.psnr_f32,
        row.us_per_ray,
        row.samples_per_ray
    );
}

fn save(a: &Args, rows: &[Row]) -> CmdResult {
    let (csv, md) = tables(rows, a.bits);
    write_atomic(&a.out.join("fit.csv"), csv.as_bytes())?;
    write_atomic(&a.out.join("fit.md"), md.as_bytes())
}

/// Feature-table size (log2 entries per level) below which `nerf fit`
/// coarsens the occupancy grid first: on lego at 64 KiB a 2¹⁰ table with a
/// 32³ grid reached 28.64 dB in int8 after 10 minutes, where the 64³ grid
/// with a 2⁸ table fell behind the 4x64 network (docs/EXPERIMENTS.md, "On a
/// Cortex-M").
pub const TABLE_FLOOR_LOG2: u8 = 10;

/// Runs `nerf fit`.
pub fn run(a: Args) -> CmdResult {
    // everything checked before the first candidate trains
    super::refuse_inside(&a.out, "--out", &a.data)?;
    let (downscale, capture) = (a.capture.downscale.unwrap_or(1), a.capture);
    let data = super::load_split(&a.data, Split::Train, downscale, capture)?;
    data.check_rays().map_err(CmdError::file(&a.data))?;
    let scene = data.scene;
    drop(data);
    super::load_split(&a.data, Split::Val, downscale, capture)
        .map_err(|e| e.noted(" (nerf fit scores candidates on the validation views)"))?;
    // one process per output folder (a train or another fit started into it
    // is refused); an earlier fit's results replaced only with --force
    let _out = super::outdir::OutDir::claim(&a.out, "--out", "fit", super::outdir::Earlier::NeedForce, a.force)?;
    let mut rows = Vec::new();
    // per candidate that reached the target: name, samples, µs/ray, cost per ray
    let mut reached: Vec<(&'static str, u16, f64, usize)> = Vec::new();
    // without a target: name, samples, PSNR, µs/ray of every candidate trained
    let mut accurate: Vec<(&'static str, u16, f64, f64)> = Vec::new();
    for (name, cfg) in candidates() {
        let (cfg, gave_up) = match a.max_bytes {
            None => (cfg, Vec::new()),
            Some(max) => match fit_budget(&cfg, scene, a.bits, max).map_err(CmdError::within(name))? {
                Ok((c, gave, bytes)) => {
                    let what =
                        if gave.is_empty() { String::new() } else { format!(" after giving up {}", gave.join(", ")) };
                    out!("fit: {name} fits --max-bytes {max}: {bytes} bytes{what}");
                    (c, gave)
                }
                Err(smallest) => {
                    out!("fit: not training {name}: it does not fit --max-bytes {max} ({smallest} bytes at its smallest)");
                    continue;
                }
            },
        };
        let least = cost_per_ray(&cfg, cfg.sampling.n_coarse.div_ceil(3));
        if let Some(best) = reached.iter().map(|r| r.3).min() {
            if least >= best {
                out!("fit: not training {name}: even at a third of its samples it costs more per ray ({least} vs {best})");
                continue;
            }
        }
        out!("fit: training {name} ({} MAC/sample, cost {}) for {} min", macs(&cfg), cost(&cfg), a.minutes);
        let row = Row { gave_up: gave_up.join("; "), ..try_one(&a, name, &cfg)? };
        report(&a, &row);
        if let Some(max) = a.max_bytes.filter(|&m| row.bytes > m) {
            // the trained model came out larger than its random-weight twin (not expected: kept out of the choice)
            out!("fit: {name} is {} bytes after training, over --max-bytes {max}; not kept", row.bytes);
            rows.push(row);
            save(&a, &rows)?;
            continue;
        }
        let ok = a.target_psnr.is_some_and(|t| row.psnr_fixed >= t);
        if a.target_psnr.is_none() {
            accurate.push((name, row.coarse, row.psnr_fixed, row.us_per_ray));
        }
        rows.push(row);
        save(&a, &rows)?;
        if ok {
            let first = rows.last().cloned().expect("just pushed");
            let (coarse, us) = fewest_samples(&a, name, &cfg, &first, &mut rows)?;
            reached.push((name, coarse, us, cost_per_ray(&cfg, coarse)));
        }
    }
    out!("{}", tables(&rows, a.bits).1);
    let Some(target) = a.target_psnr else {
        // --max-bytes alone: the most accurate candidate that fits
        let Some(&(name, coarse, psnr, us)) = accurate.iter().max_by(|x, y| x.2.total_cmp(&y.2)) else {
            return Err(CmdError::Unreached(format!("no candidate fits --max-bytes {}", a.max_bytes.unwrap_or(0))));
        };
        return keep(&a, name, coarse, &format!("{psnr:.2} dB, {us:.1} µs/ray"), &rows);
    };
    // the lowest measured µs per ray of the fixed-point render
    let Some(&(name, coarse, us, _)) = reached.iter().min_by(|x, y| x.2.total_cmp(&y.2)) else {
        let best = rows.iter().map(|r| r.psnr_fixed).fold(f64::NEG_INFINITY, f64::max);
        return Err(CmdError::Unreached(format!(
            "no candidate reached {:.2} dB in {} min (best {best:.2} dB); table in {}",
            target,
            a.minutes,
            a.out.join("fit.md").display()
        )));
    };
    keep(&a, name, coarse, &format!("{us:.1} µs/ray"), &rows)
}

/// Writes candidate `name` at `coarse` samples per ray as the fit's
/// models and says what was chosen (`why`) and what it gave up.
fn keep(a: &Args, name: &str, coarse: u16, why: &str, rows: &[Row]) -> CmdResult {
    let dir = a.out.join(name);
    for f in ["model.nerf", "model_fixed.nerf"] {
        with_coarse(&dir.join(f), coarse, &a.out.join(f))?;
    }
    let gave = rows.iter().find(|r| r.name == name).map(|r| r.gave_up.clone()).unwrap_or_default();
    let gave = if gave.is_empty() { String::new() } else { format!("; to fit --max-bytes it gave up {gave}") };
    out!(
        "fit: chose {name} at {coarse} samples per ray ({why}){gave}; wrote {} and {}",
        a.out.join("model.nerf").display(),
        a.out.join("model_fixed.nerf").display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nerf_infer::format::Scene;
    use std::num::NonZeroU16;

    fn lego_scene() -> Scene {
        Scene::blender(1.5, 2.0, 6.0)
    }

    #[test]
    fn a_byte_budget_coarsens_the_occupancy_grid_before_the_feature_table_goes_below_its_floor() {
        let f = TrainConfig::features();
        // 64 KiB: a 2^10 table (32 KiB) and a 32^3 grid (4 KiB) fit, a 64^3 grid (32 KiB) beside it does not
        let (c, gave, bytes) = fit_budget(&f, lego_scene(), Scheme::I8, 65_536).unwrap().unwrap();
        assert_eq!((c.features.log2_table, c.grid.res), (TABLE_FLOOR_LOG2, NonZeroU16::new(32)), "{gave:?}");
        assert!(bytes <= 65_536);
        assert_eq!(gave, ["feature table 2^15 -> 2^10 entries per level", "occupancy grid 64^3 -> 32^3"]);
        // a roomy budget gives up nothing; a tight one goes below the floor; the layers alone exceed 4 000 B
        let (c, gave, _) = fit_budget(&f, lego_scene(), Scheme::I8, 1 << 20).unwrap().unwrap();
        assert_eq!((c.features.log2_table, c.grid.res, gave.len()), (15, NonZeroU16::new(64), 0));
        let (c, _, bytes) = fit_budget(&f, lego_scene(), Scheme::I8, 40_000).unwrap().unwrap();
        assert!(
            c.features.log2_table < TABLE_FLOOR_LOG2 && c.grid.res == NonZeroU16::new(32) && bytes <= 40_000,
            "{c:?}"
        );
        assert!(fit_budget(&f, lego_scene(), Scheme::I8, 4_000).unwrap().is_err());
    }
}
