//! Per-ray cost of the kernel's f32 and fixed-point paths, for the paper's
//! network (8×256, L = 10/4, 64 + 128 samples: 64 coarse evaluations of
//! the trunk and density, 192 fine evaluations of the whole network) and
//! the fast preset (4×64, L = 8/2, 48 + 48), and the features preset (2×64
//! behind an 8-level learned feature grid, 192 samples in one pass; its
//! MAC count leaves out the feature lookups). Models have random weights
//! (He-uniform, calibrated); the work per ray does not depend on them
//! except through ReLU sparsity and early termination (off here).
//!
//! Per tile: an 8×8 tile (64 rays) through `render_tile`, the entry point
//! an embedding binary calls.
//!
//! Empty-space skipping: a whole view of the shipped grid model, with and
//! without its occupancy grid and early termination (`frame/grid-model`).
//!
//! `cargo bench --bench per_ray` — criterion reports each time with its
//! throughput in MAC/s (`thrpt`, elements = multiply-accumulates); compare
//! with the machine's peak from `cargo bench --bench peak`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nerf_infer::format::Scene;
use nerf_infer::Orbit;
use nerf_infer::{render_tile, Tile};
use nerf_infer::{Model, RayRenderer, RenderOptions, RendererF32, RendererFixed, Scheme, ScratchF32, ScratchFixed};
use nerf_train::config::TrainConfig;
use nerf_train::export::{quantise, random_model, OwnedModel};
use std::hint::black_box;

fn scene() -> Scene {
    Scene::blender(1.5, 2.0, 6.0)
}

/// Multiply-accumulates per ray: coarse pass (trunk + density head only)
/// and fine pass (all layers, view-direction part once per ray).
fn macs_per_ray(m: &Model<'_>) -> usize {
    let net = &m.coarse;
    let d = m.topology.depth as usize;
    let trunk: usize = net.layers[..=d].iter().map(|l| l.in_dim as usize * l.out_dim as usize).sum();
    let all: usize = net.layers.iter().map(|l| l.in_dim as usize * l.out_dim as usize).sum();
    let (nc, nf) = (m.samples.coarse as usize, m.samples.fine as usize);
    if nf > 0 {
        nc * trunk + (nc + nf) * all
    } else {
        nc * all
    }
}

/// The 8×8 tile of the per-tile benchmark (all its rays cross the bounds).
const TILE: Tile = Tile { x0: 12, y0: 12, width: 8, height: 8 };

fn bench(c: &mut Criterion) {
    let cam = Orbit::new(&scene(), None).camera(0.2, 32, 32).unwrap();
    let rays: Vec<_> = (0..64u32).map(|k| (cam.ray(8 + k % 16, 8 + k / 4), (k, 0))).collect();
    let presets =
        [("paper", TrainConfig::paper()), ("fast", TrainConfig::fast()), ("features", TrainConfig::features())];
    for (name, cfg) in presets {
        let f = random_model(&cfg, scene(), 1, 4.0).unwrap().to_bytes().unwrap();
        let mf = Model::from_bytes(&f).unwrap();
        let q16 = quantise(&mf, Scheme::I16).unwrap().to_bytes().unwrap();
        let q8 = quantise(&mf, Scheme::I8).unwrap().to_bytes().unwrap();
        let macs = macs_per_ray(&mf) as u64;
        println!("{name}: {macs} MACs per ray");
        let rf = RendererF32::new(&mf, RenderOptions::from_model(&mf)).unwrap();
        let mut sf = Box::<ScratchF32<8>>::default();
        let qs: Vec<_> = [("int16", &q16), ("int8", &q8)].map(|(l, b)| (l, Model::from_bytes(b).unwrap())).into();
        let rqs: Vec<_> =
            qs.iter().map(|(l, m)| (*l, RendererFixed::new(m, RenderOptions::from_model(m)).unwrap())).collect();
        let mut sq = Box::<ScratchFixed<8>>::default();
        let samples = if name == "paper" { 20 } else { 60 };

        let mut g = c.benchmark_group(format!("per_ray/{name}"));
        g.sample_size(samples).throughput(Throughput::Elements(macs));
        let mut k = 0;
        g.bench_function("f32", |b| {
            b.iter(|| {
                let ((o, d), px) = rays[k % rays.len()];
                k += 1;
                black_box(rf.render_ray(o, d, px, &mut sf))
            })
        });
        for (label, rq) in &rqs {
            g.bench_function(*label, |b| {
                b.iter(|| {
                    let ((o, d), px) = rays[k % rays.len()];
                    k += 1;
                    black_box(rq.render_ray(o, d, px, &mut sq))
                })
            });
        }
        g.finish();

        // the MAC count assumes every ray of the tile evaluates every sample
        // (models without an occupancy grid; a fresh grid model's grid is
        // all occupied, but its rays are clipped to the bounds)
        let (nc, nf) = (mf.samples.coarse as u64, mf.samples.fine as u64);
        let mut out_q = vec![Default::default(); TILE.len()];
        sq.evaluations = 0;
        render_tile(&rqs[0].1, &cam, TILE, &mut sq, &mut out_q).unwrap();
        if mf.grid.is_none() {
            assert_eq!(sq.evaluations, TILE.len() as u64 * (2 * nc + nf));
        }

        let mut g = c.benchmark_group(format!("per_tile/{name}"));
        g.sample_size(10).throughput(Throughput::Elements(macs * TILE.len() as u64));
        let mut out_f = vec![Default::default(); TILE.len()];
        g.bench_function("f32", |b| b.iter(|| render_tile(&rf, &cam, TILE, &mut sf, black_box(&mut out_f)).unwrap()));
        for (label, rq) in &rqs {
            g.bench_function(*label, |b| {
                b.iter(|| render_tile(rq, &cam, TILE, &mut sq, black_box(&mut out_q)).unwrap())
            });
        }
        g.finish();
    }
}

/// Empty-space skipping on the shipped grid model of the built-in scene
/// (`models/scene_grid.nerf`, 4×64, 192 samples): a whole 32×32 orbit view
/// (throughput in rays), f32 and int8, with the grid and with it removed,
/// without and with early termination at 10⁻³.
fn bench_grid(c: &mut Criterion) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/scene_grid.nerf");
    let f = std::fs::read(path).expect("models/scene_grid.nerf");
    let mf = Model::from_bytes(&f).unwrap();
    let owned = OwnedModel::from_model(&mf);
    let q8 = quantise(&mf, Scheme::I8).unwrap();
    let mut bytes = Vec::new();
    for (label, m) in [("f32", &owned), ("int8", &q8)] {
        bytes.push((format!("{label}/grid"), m.to_bytes().unwrap()));
        bytes.push((format!("{label}/no-grid"), OwnedModel { grid: None, ..m.clone() }.to_bytes().unwrap()));
    }
    let cam = Orbit::new(&mf.scene, None).camera(0.2, 32, 32).unwrap();
    let frame = Tile { x0: 0, y0: 0, width: 32, height: 32 };
    let mut g = c.benchmark_group("frame/grid-model");
    g.sample_size(10).throughput(Throughput::Elements(frame.len() as u64));
    for (label, b) in &bytes {
        let m = Model::from_bytes(b).unwrap();
        for ert in [0.0, 1e-3] {
            let opts = RenderOptions { early_stop: ert, ..RenderOptions::from_model(&m) };
            let name = if ert > 0.0 { format!("{label}/ert") } else { label.clone() };
            if m.scheme() == Scheme::F32 {
                let r = RendererF32::new(&m, opts).unwrap();
                let mut s = Box::<ScratchF32<8>>::default();
                let mut out = vec![Default::default(); frame.len()];
                render_tile(&r, &cam, frame, &mut s, &mut out).unwrap();
                println!("{name}: {:.1} samples per ray", s.evaluations as f64 / frame.len() as f64);
                g.bench_function(name, |b| {
                    b.iter(|| render_tile(&r, &cam, frame, &mut s, black_box(&mut out)).unwrap())
                });
            } else {
                let r = RendererFixed::new(&m, opts).unwrap();
                let mut s = Box::<ScratchFixed<8>>::default();
                let mut out = vec![Default::default(); frame.len()];
                render_tile(&r, &cam, frame, &mut s, &mut out).unwrap();
                println!("{name}: {:.1} samples per ray", s.evaluations as f64 / frame.len() as f64);
                g.bench_function(name, |b| {
                    b.iter(|| render_tile(&r, &cam, frame, &mut s, black_box(&mut out)).unwrap())
                });
            }
        }
    }
    g.finish();
}

criterion_group!(benches, bench, bench_grid);
criterion_main!(benches);
