//! Cost of one training step, and of the matrix products inside it.
//!
//! - `train_step/PRESET`: one [`Trainer::train_step`] of the `features`
//!   preset (the default) and of `fast` on the built-in scene at 64×64
//!   (1024 rays per step; throughput in rays), after 200 warm-up steps so
//!   that the occupancy grid has been refreshed from a fitted density.
//! - `gemm/MxNxK`: the `gemm` crate's product (`nerf_train::util::gemm::matmul`,
//!   one thread) at the shapes of the default's hidden layers, `M` samples
//!   by 64 outputs by 64 inputs, for the samples of one 32-ray chunk at
//!   about 10 samples per ray and of larger chunks; throughput in
//!   multiply-accumulates. Read the layers' GFLOP/s per thread that
//!   `nerf train` reports (`mlp_gflops_per_thread`) against these.
//! - `adam/table`: one [`Adam::update_averaged`] of a feature grid's table
//!   the size of flower's at 1008×756 (about 6.3 M values; 40 % of them with
//!   a gradient, the others skipped), its moving average and the zeroing of
//!   the gradient it read, on all threads; throughput in table values. Read `nerf train`'s `adam` stage against it.
//!
//! `cargo bench --bench train_step`

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use nerf_train::config::TrainConfig;
use nerf_train::dataset::synthetic::{write_blender, SceneSpec};
use nerf_train::dataset::{load, LoadOptions, Split};
use nerf_train::optim::adam::Adam;
use nerf_train::train::Trainer;
use nerf_train::util::gemm::{matmul, View};
use std::hint::black_box;

fn steps(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let dir = dir.path();
    write_blender(dir, SceneSpec { size: 64, train: 24, val: 1, test: 1 }).expect("write the built-in scene");
    let data = load(dir, Split::Train, LoadOptions::default()).expect("load the built-in scene");
    let mut g = c.benchmark_group("train_step");
    g.sample_size(20);
    for (name, cfg) in [("features", TrainConfig::features()), ("fast", TrainConfig::fast())] {
        g.throughput(Throughput::Elements(cfg.sampling.batch_rays as u64));
        let mut tr = Trainer::new(cfg, data.scene, 1, 1).unwrap();
        for i in 0..200 {
            tr.train_step(&data, i as f64 / 1000.0);
        }
        g.bench_function(name, |b| b.iter(|| black_box(tr.train_step(&data, 0.2).loss)));
    }
    g.finish();
}

fn products(c: &mut Criterion) {
    let mut g = c.benchmark_group("gemm");
    let (n, k) = (64, 64);
    for m in [320, 1280, 5120] {
        let a: Vec<f32> = (0..m * k).map(|i| (i % 7) as f32 * 0.1).collect();
        let w: Vec<f32> = (0..k * n).map(|i| (i % 5) as f32 * 0.1).collect();
        let mut out = vec![0.0f32; m * n];
        g.throughput(Throughput::Elements((m * n * k) as u64));
        g.bench_function(format!("{m}x{n}x{k}"), |b| {
            b.iter(|| matmul(m, n, k, black_box(&mut out), n, false, View::rows(&a, k), View::rows(&w, n)))
        });
    }
    g.finish();
}

fn adam(c: &mut Criterion) {
    let mut g = c.benchmark_group("adam");
    g.sample_size(20);
    // flower's table at 1008×756: the default's 8 levels of 2 values sized to 4 096 cells and 2¹⁹ entries
    let mut cfg = TrainConfig::features();
    cfg.fit_features_to(4096);
    let grid = cfg.feature_grid().expect("a feature grid");
    let n = (0..grid.levels()).map(|l| grid.entries(l)).sum::<usize>() * grid.width as usize;
    // 4 values in 10 with a gradient, spread evenly over the table
    let grad: Vec<f32> = (0..n as u64)
        .map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32)
        .map(|h| (h % 10 < 4) as u8 as f32 * 1e-3)
        .collect();
    let (mut p, mut average) = (vec![0.1f32; n], vec![0.1f32; n]);
    let mut adam = Adam::new(n, n);
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("table", |b| {
        // a fresh copy of the gradient each time (not timed): the update leaves it zeroed
        b.iter_batched_ref(
            || grad.clone(),
            |g| adam.update_averaged(&mut p, black_box(g), 1e-2, 0.9, 0.99, 1e-15, 0.0, Some((&mut average, 0.999))),
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, steps, products, adam);
criterion_main!(benches);
