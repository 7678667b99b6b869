//! The learned feature grid (format version 3): training with it, its file
//! format, and its fixed-point render against the f32 one.

mod support;

use nerf_infer::format::FORMAT_VERSION_NO_CAPTURE;
use nerf_infer::Orbit;
use nerf_infer::{Model, RenderOptions, Scheme};
use nerf_train::config::TrainConfig;
use nerf_train::dataset::synthetic::{write_blender, SceneSpec};
use nerf_train::dataset::{load, LoadOptions, Split};
use nerf_train::eval::score_view;
use nerf_train::export::{narrow_table, quantise, random_model, trainer_model, OwnedModel, Prune};
use nerf_train::train::{Draw, Trainer};
use nerf_train::util::rng::Rng;
use std::num::{NonZeroU16, NonZeroU8};
use support::*;

/// A small grid model: 4 levels of 2 values, 2¹⁰ entries (the two coarse
/// levels dense, the two fine ones hashed), γ(x) with 2 frequencies.
fn feature_config() -> TrainConfig {
    TrainConfig::fast().with(|c| {
        c.model.depth = 2;
        c.model.width = 32;
        c.model.skips = vec![];
        c.model.view_width = 16;
        c.model.pos_freqs = 2;
        c.model.dir_freqs = 2;
        c.sampling.n_coarse = 48;
        c.sampling.n_fine = None;
        c.features.levels = NonZeroU8::new(4);
        c.features.width = 2;
        c.features.log2_table = 10;
        c.features.min_res = 4;
        c.features.max_res = 32;
    })
}

#[test]
fn a_step_reports_the_time_of_each_of_its_stages_within_its_own_duration() {
    let d = support::TestDir::new("step-times-test");
    write_blender(&d, SceneSpec { size: 24, train: 4, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let cfg = feature_config().with(|c| {
        c.sampling.batch_rays = 256;
        c.grid.res = NonZeroU16::new(16);
        c.grid.warmup = 0;
        c.grid.every = 2;
    });
    let mut tr = Trainer::new(cfg, data.scene, 1, 1).unwrap();
    for _ in 0..4 {
        let start = std::time::Instant::now();
        let st = tr.train_step(&data, 0.5);
        let took = start.elapsed().as_secs_f64();
        let t = st.times;
        let grid_step = (tr.step - 1).is_multiple_of(2);
        assert_eq!(t.grid > 0.0, grid_step, "grid refreshed at step {}: {t:?}", tr.step - 1);
        for (name, v) in t.stages() {
            assert!(v >= 0.0 && v.is_finite(), "{name}: {v}");
            assert!(v > 0.0 || name == "grid", "{name} not timed: {t:?}");
        }
        // the wall stages run one after the other within the step
        assert!(t.wall() <= took, "stages {} s in a step of {took} s", t.wall());
        // the chunks' split is thread time: at most the threads' share of the wall time
        let threads = rayon::current_num_threads() as f64;
        let split = t.thread();
        assert!(split <= threads * t.chunks, "split {split} s over {threads} threads of {} s", t.chunks);
    }
}

fn version(bytes: &[u8]) -> u16 {
    u16::from_le_bytes([bytes[4], bytes[5]])
}

#[test]
fn a_feature_grid_model_trains_and_renders_in_both_numeric_paths() {
    let d = support::TestDir::new("features-test");
    write_blender(&d, SceneSpec { size: 24, train: 12, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let val = load(&d, Split::Val, LoadOptions::default()).unwrap();
    let cfg = feature_config().with(|c| {
        c.sampling.batch_rays = 256;
        c.optimiser.lr = 1e-2;
        c.optimiser.eps = 1e-15;
        c.optimiser.beta2 = 0.99;
    });
    let mut tr = Trainer::new(cfg, data.scene, 1, 1).unwrap();
    support::train_until_the_loss_halves(&mut tr, &data);
    let mlp = tr.mlp();
    let table = &tr.field.params[mlp.table..];
    assert!(table.iter().any(|v| v.abs() > 1e-2), "the table did not move from its ±1e-4 start");
    let back = Trainer::from_bytes(&tr.to_bytes().unwrap()).unwrap();
    assert_eq!(back.field.params, tr.field.params);

    let calib = Trainer::draw_batch(&data, 512, Draw::CENTRES, &mut Rng::new(3));
    let bytes = trainer_model(&tr, &calib, Prune::Off).to_bytes().unwrap();
    assert_eq!(version(&bytes), FORMAT_VERSION_NO_CAPTURE);
    let m = Model::from_bytes(&bytes).unwrap();
    let f = m.features.as_ref().expect("the model carries its feature grid");
    // levels of 4, 8, 16, 32 cells: 125 and 729 vertices (dense), then 2¹⁰ entries (hashed)
    assert_eq!(f.resolutions.as_slice(), &[4, 8, 16, 32]);
    assert_eq!((0..4).map(|l| f.entries(l)).collect::<Vec<_>>(), [125, 729, 1024, 1024]);
    assert_eq!(m.encoding.grid_dim, 8);
    assert_eq!(m.feature_bytes(), 4 * table.len());
    assert_eq!(nerf_infer::format::read_f32(f.table, 77), table[77]);

    let score = |m: &Model<'_>| score_view(m, RenderOptions::from_model(m), &val.views[0]).unwrap().1.psnr;
    let white = vec![[1.0f32; 3]; val.views[0].rgb.len()];
    let base = nerf_train::metrics::psnr(&white, &val.views[0].rgb);
    let f_gt = score(&m);
    let q16 = quantise(&m, Scheme::I16).unwrap().to_bytes().unwrap();
    let q8 = quantise(&m, Scheme::I8).unwrap().to_bytes().unwrap();
    let (m16, m8) = (Model::from_bytes(&q16).unwrap(), Model::from_bytes(&q8).unwrap());
    assert_eq!(m8.feature_bytes(), 2 * table.len(), "fixed-point tables are i16");
    let (q16_gt, q8_gt) = (score(&m16), score(&m8));
    println!("validation PSNR f32 {f_gt:.3}, int16 {q16_gt:.3}, int8 {q8_gt:.3} dB (all-white {base:.2} dB)");
    assert!(f_gt > base + 3.0);
    assert!(q16_gt >= f_gt - 0.1, "int16 loses {:.3} dB", f_gt - q16_gt);
    assert!(q8_gt >= f_gt - 0.5, "int8 loses {:.3} dB", f_gt - q8_gt);
    // the int8 model with its table as 8- and 4-bit codebook indices
    for (bits, most_loss) in [(8, 0.1), (4, 1.0)] {
        let mut owned = quantise(&m, Scheme::I8).unwrap();
        narrow_table(&mut owned, bits).unwrap();
        let bytes = owned.to_bytes().unwrap();
        let mn = Model::from_bytes(&bytes).unwrap();
        let gt = score(&mn);
        println!("{bits}-bit table: {gt:.3} dB, {} table bytes", mn.feature_bytes());
        assert!(gt >= q8_gt - most_loss, "{bits}-bit table loses {:.3} dB", q8_gt - gt);
    }
}

#[test]
fn the_model_takes_the_average_of_the_parameters_over_the_last_steps() {
    let d = support::TestDir::new("ema-test");
    write_blender(&d, SceneSpec { size: 24, train: 6, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let cfg = feature_config().with(|c| {
        c.sampling.batch_rays = 128;
        c.grid.res = NonZeroU16::new(16);
        c.grid.warmup = 0;
        c.grid.every = 4;
        c.optimiser.ema_decay = 0.9;
    });
    let mut tr = Trainer::new(cfg.clone(), data.scene, 1, 2).unwrap();
    tr.train_step(&data, 0.0);
    assert_eq!(tr.field.ema, tr.field.params, "the average starts at the first step's parameters");
    for n in 1..40u64 {
        let before = tr.field.ema.clone();
        tr.train_step(&data, n as f64 / 40.0);
        // the decay grows with the steps to its configured value
        let b = 0.9f32.min((1 + n) as f32 / (10 + n) as f32);
        let want: Vec<f32> = before.iter().zip(&tr.field.params).map(|(&a, &p)| a + (1.0 - b) * (p - a)).collect();
        assert_eq!(tr.field.ema, want, "step {n}");
    }
    assert_ne!(tr.field.ema, tr.field.params);
    let back = Trainer::from_bytes(&tr.to_bytes().unwrap()).unwrap();
    assert_eq!(back.field.ema, tr.field.ema, "checkpoints keep the average");

    // the model holds the average, the run goes on with its own parameters
    let calib = Trainer::draw_batch(&data, 256, Draw::CENTRES, &mut Rng::new(3));
    let bytes = trainer_model(&tr, &calib, Prune::Off).to_bytes().unwrap();
    let m = Model::from_bytes(&bytes).unwrap();
    let table = m.features.as_ref().unwrap().table;
    let t0 = tr.mlp().table;
    let read: Vec<f32> = (0..tr.field.params.len() - t0).map(|k| nerf_infer::format::read_f32(table, k)).collect();
    assert_eq!(read, tr.field.ema[t0..], "the model's table is the average's");
    let averaged = tr.averaged();
    assert_eq!(averaged.field.params, tr.field.ema);
    assert_eq!(averaged.step, tr.step);
    // its occupancy grid refreshed once more, from the average's density
    let (run, avg) = (tr.sampler.occupancy.as_ref().unwrap(), averaged.sampler.occupancy.as_ref().unwrap());
    assert_eq!(avg.updates, run.updates + 1);

    // before the run's first refresh its grid stays whole in the average's model too
    let mut young = Trainer::new(cfg.clone().with(|c| c.grid.warmup = 1000), data.scene, 1, 2).unwrap();
    for _ in 0..3 {
        young.train_step(&data, 0.0);
    }
    assert_eq!(young.averaged().field.params, young.field.ema);
    assert_eq!(young.averaged().sampler.occupancy, young.sampler.occupancy);
    assert_eq!(young.sampler.occupancy.as_ref().unwrap().updates, 0);

    // without an average the model is the run's last step
    let mut plain = Trainer::new(cfg.with(|c| c.optimiser.ema_decay = 0.0), data.scene, 1, 2).unwrap();
    plain.train_step(&data, 0.0);
    assert!(plain.field.ema.is_empty() && std::ptr::eq(&*plain.averaged(), &plain));
}

#[test]
fn a_table_value_moves_only_in_the_steps_that_give_it_a_gradient() {
    let d = support::TestDir::new("sparse-adam-test");
    write_blender(&d, SceneSpec { size: 24, train: 12, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    // few rays per step, a fine hashed level: most values get a gradient now and then
    let cfg = feature_config().with(|c| {
        c.sampling.batch_rays = 16;
        c.features.log2_table = 14;
        c.optimiser.lr = 1e-2;
        c.optimiser.eps = 1e-15;
        c.optimiser.beta2 = 0.99;
    });
    let mut tr = Trainer::new(cfg, data.scene, 1, 4).unwrap();
    let table = tr.mlp().table;
    assert_eq!(tr.field.adam.steps.len(), tr.field.params.len() - table);
    let (mut moved, mut kept) = (0, 0);
    for _ in 0..30 {
        let (before, steps) = (tr.field.params.clone(), tr.field.adam.steps.clone());
        tr.train_step(&data, 0.0);
        for (i, (&now, &then)) in tr.field.adam.steps.iter().zip(&steps).enumerate() {
            assert!(now - then <= 1, "value {i} counted twice in a step");
            if now > then {
                moved += 1;
            } else {
                assert_eq!(tr.field.params[table + i], before[table + i], "value {i} moved without a gradient");
                kept += (then > 0) as usize;
            }
        }
    }
    println!("{moved} value updates, {kept} times a value updated before kept it");
    assert!(moved > 1000 && kept > 1000, "{moved} updates, {kept} kept");
    assert!(tr.field.adam.steps.contains(&0), "some values never had a gradient");
    let back = Trainer::from_bytes(&tr.to_bytes().unwrap()).unwrap();
    assert_eq!(back.field.adam.steps, tr.field.adam.steps);
}

#[test]
fn int16_render_of_a_random_feature_grid_model_is_within_40_db_of_f32() {
    for seed in [1, 2] {
        let f32_bytes = random_model(&feature_config(), unit_scene(), seed, 8.0).unwrap().to_bytes().unwrap();
        let m32 = Model::from_bytes(&f32_bytes).unwrap();
        let q_bytes = quantise(&m32, Scheme::I16).unwrap().to_bytes().unwrap();
        let m16 = Model::from_bytes(&q_bytes).unwrap();
        // without its feature grid the same network renders another image:
        // the grid's values reach the pixels
        let mut plain = OwnedModel::from_model(&m32);
        plain.features = None;
        plain.encoding.grid_dim = 0;
        let l0 = &mut plain.coarse.layers[0];
        l0.in_dim -= 8; // the grid's rows are the last 8 of layer 0
        l0.weights.truncate(l0.weights.len() - 8 * 32 * 4);
        let plain_bytes = plain.to_bytes().unwrap();
        let mp = Model::from_bytes(&plain_bytes).unwrap();
        for turn in [0.1, 0.6] {
            let cam = Orbit::new(&m32.scene, None).camera(turn, 32, 32).unwrap();
            let (a, b) = (render(&m32, &cam), render(&m16, &cam));
            let p = psnr(&a, &b);
            let without = psnr(&a, &render(&mp, &cam));
            println!("seed {seed} view {turn}: int16 vs f32 {p:.2} dB; without the grid {without:.2} dB");
            assert!(p >= 40.0, "PSNR {p:.2} dB < 40 dB");
            assert!(without < 30.0, "the feature grid changes little: {without:.2} dB");
        }
    }
}

#[test]
fn the_format_keeps_old_versions_and_checks_the_table() {
    // models without a feature grid are written as before, byte for byte
    // (golden8.nerf: an int8 model written before format version 6)
    for name in ["models/scene.nerf", "models/scene_grid.nerf", "nerf-infer/tests/data/golden8.nerf"] {
        // the workspace's root, above this crate's folder
        let bytes = std::fs::read(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(name)).unwrap();
        let m = Model::from_bytes(&bytes).unwrap();
        assert!(version(&bytes) < FORMAT_VERSION_NO_CAPTURE);
        assert_eq!(OwnedModel::from_model(&m).to_bytes().unwrap(), bytes, "{name}");
    }
    let owned = random_model(&feature_config(), unit_scene(), 3, 8.0).unwrap();
    let bytes = owned.to_bytes().unwrap();
    assert_eq!(OwnedModel::from_model(&Model::from_bytes(&bytes).unwrap()), owned);
    // a table one entry short, or a grid_dim that disagrees, is refused
    let mut short = owned.clone();
    short.features.as_mut().unwrap().1.truncate(4 * 1023 * 2);
    assert!(short.to_bytes().is_err());
    let mut wrong = owned.clone();
    wrong.features.as_mut().unwrap().0.width = 1;
    assert!(wrong.to_bytes().is_err());
    // an older reader's version number on a version-3 payload does not decode
    let mut old = bytes.clone();
    old[4] = 2;
    assert!(Model::from_bytes(&old).is_err());
}

/// The table of an integer model as i16 values, whatever its storage.
fn table_values(m: &Model<'_>) -> Vec<i16> {
    let f = m.features.as_ref().unwrap();
    let w = f.width as usize;
    (0..f.levels())
        .flat_map(|l| (f.offset(l) * w..f.offset(l + 1) * w).map(move |k| (l, k)))
        .map(|(l, k)| match f.narrow {
            Some(n) => n.value(f.table, l, k) as i16,
            None => nerf_infer::format::read_i16(f.table, k),
        })
        .collect()
}

#[test]
fn a_narrow_table_renders_as_the_i16_table_of_its_codebook_values_would() {
    let f32_bytes = random_model(&feature_config(), unit_scene(), 4, 8.0).unwrap().to_bytes().unwrap();
    let m32 = Model::from_bytes(&f32_bytes).unwrap();
    let wide = quantise(&m32, Scheme::I8).unwrap();
    let wide_bytes = wide.to_bytes().unwrap();
    let mw = Model::from_bytes(&wide_bytes).unwrap();
    for bits in [8u8, 4] {
        let mut owned = wide.clone();
        narrow_table(&mut owned, bits).unwrap();
        let bytes = owned.to_bytes().unwrap();
        assert_eq!(version(&bytes), nerf_infer::format::FORMAT_VERSION_NO_ORBIT);
        let mn = Model::from_bytes(&bytes).unwrap();
        assert_eq!(OwnedModel::from_model(&mn), owned, "{bits}-bit table: the file round trips");
        let values = mw.features.as_ref().unwrap().values();
        // the indices padded to whole 4-byte words, and 4 levels' codebooks
        assert_eq!(mn.feature_bytes(), (values * bits as usize).div_ceil(32) * 4 + 2 * (4 << bits));
        // the file shrinks by what the table does, give or take the record's few bytes
        let saved = wide_bytes.len() as i64 - bytes.len() as i64;
        assert!((saved - (2 * values - mn.feature_bytes()) as i64).abs() <= 8, "{bits}-bit table saves {saved} B");
        // the i16 table that holds each index's codebook value renders the same, bit for bit
        let expanded = table_values(&mn);
        let mut as_i16 = wide.clone();
        as_i16.features.as_mut().unwrap().1 = expanded.iter().flat_map(|v| v.to_le_bytes()).collect();
        let as_i16_bytes = as_i16.to_bytes().unwrap();
        let me = Model::from_bytes(&as_i16_bytes).unwrap();
        for turn in [0.2, 0.7] {
            let cam = Orbit::new(&mn.scene, None).camera(turn, 24, 24).unwrap();
            assert_eq!(render(&mn, &cam), render(&me, &cam), "{bits}-bit table, view {turn}");
        }
        // a narrow table is not narrowed again
        let e = narrow_table(&mut owned.clone(), 4).unwrap_err().to_string();
        assert!(e.contains("already narrow"), "{e}");
        // each value is its level's nearest code
        let (f, original) = (mn.features.as_ref().unwrap(), table_values(&mw));
        let book = f.narrow.unwrap().codebook;
        for l in 0..f.levels() {
            let codes: Vec<i32> = book[2 * (l << bits)..2 * ((l + 1) << bits)]
                .chunks_exact(2)
                .map(|b| i16::from_le_bytes([b[0], b[1]]) as i32)
                .collect();
            for k in f.offset(l) * 2..f.offset(l + 1) * 2 {
                let (t, got) = (original[k] as i32, expanded[k] as i32);
                let best = codes.iter().map(|c| (c - t).abs()).min().unwrap();
                assert_eq!((got - t).abs(), best, "{bits}-bit level {l} value {k}: {t} stored as {got}");
            }
        }
    }
}

/// A model with a 4-bit table, its bytes flipped at random (the checksum
/// recomputed, half the flips in the record of the codes at the end):
/// every variant is a typed error at decoding or a model that renders
/// in-range pixels.
#[test]
fn a_corrupted_narrow_table_model_is_refused_or_renders_in_range() {
    use nerf_infer::format::{crc32, HEADER_LEN};
    let f32_bytes = random_model(&feature_config(), unit_scene(), 5, 8.0).unwrap().to_bytes().unwrap();
    let mut owned = quantise(&Model::from_bytes(&f32_bytes).unwrap(), Scheme::I8).unwrap();
    narrow_table(&mut owned, 4).unwrap();
    let blob = owned.to_bytes().unwrap();
    let tail = 2 * (4 << 4) + 8; // the codebook, its length and the bits
    let (mut decoded, mut refused) = (0, 0);
    for k in 0..3000u64 {
        let mut b = blob.clone();
        let h = (k + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let pos = if k % 2 == 0 {
            b.len() - 1 - (h >> 40) as usize % tail
        } else {
            HEADER_LEN + (h >> 40) as usize % (b.len() - HEADER_LEN)
        };
        b[pos] ^= 1 << (h & 7);
        let crc = crc32(&b[HEADER_LEN..]);
        b[10..14].copy_from_slice(&crc.to_le_bytes());
        match Model::from_bytes(&b) {
            Ok(m) => {
                decoded += 1;
                let cam = Orbit::new(&m.scene, None).camera(0.3, 6, 6).unwrap();
                // what decodes renders, in range: the decoder's checks leave the renderer nothing to refuse
                let img = nerf_train::eval::render_view(&m, RenderOptions::from_model(&m), &cam)
                    .unwrap_or_else(|e| panic!("flip {k} at {pos}: decoded, then refused by the renderer: {e}"));
                assert!(img.rgb.iter().flatten().all(|c| (0.0..=1.0).contains(c)), "flip {k} at {pos}");
            }
            Err(_) => refused += 1,
        };
    }
    println!("{decoded} variants decoded and rendered, {refused} refused");
    assert!(decoded > 500 && refused > 100, "{decoded} decoded, {refused} refused");
}

#[test]
fn a_footprint_model_records_its_pixel_and_renders_alike_in_both_numeric_paths() {
    let d = support::TestDir::new("footprint-test");
    write_blender(&d, SceneSpec { size: 24, train: 12, val: 1, test: 1 }).unwrap();
    let data = load(&d, Split::Train, LoadOptions::default()).unwrap();
    let val = load(&d, Split::Val, LoadOptions::default()).unwrap();
    let cfg = feature_config().with(|c| {
        c.sampling.batch_rays = 256;
        c.optimiser.lr = 1e-2;
        c.optimiser.eps = 1e-15;
        c.optimiser.beta2 = 0.99;
        c.features.footprint = true;
    });
    let mut tr = Trainer::new(cfg, data.scene, 1, 1).unwrap();
    support::train_until_the_loss_halves(&mut tr, &data);
    assert_eq!(tr.pixel, data.pixel_angle());
    let back = Trainer::from_bytes(&tr.to_bytes().unwrap()).unwrap();
    assert_eq!(back.pixel, tr.pixel);

    let calib = Trainer::draw_batch(&data, 512, Draw::CENTRES, &mut Rng::new(3));
    let owned = trainer_model(&tr, &calib, Prune::Off);
    let bytes = owned.to_bytes().unwrap();
    // the footprint's version (an object scene has no proposal grid)
    assert_eq!(version(&bytes), nerf_infer::format::FORMAT_VERSION_NO_PROPOSAL);
    let m = Model::from_bytes(&bytes).unwrap();
    assert_eq!(m.footprint.map(|f| f.pixel), Some(data.pixel_angle()));

    let score = |m: &Model<'_>| score_view(m, RenderOptions::from_model(m), &val.views[0]).unwrap().1.psnr;
    let f_gt = score(&m);
    let lines = OwnedModel { footprint: None, ..owned.clone() }.to_bytes().unwrap();
    let line_gt = score(&Model::from_bytes(&lines).unwrap());
    let q16 = quantise(&m, Scheme::I16).unwrap().to_bytes().unwrap();
    let q8 = quantise(&m, Scheme::I8).unwrap().to_bytes().unwrap();
    let (m16, m8) = (Model::from_bytes(&q16).unwrap(), Model::from_bytes(&q8).unwrap());
    assert_eq!(m16.footprint, m.footprint, "quantised models keep the footprint");
    let (q16_gt, q8_gt) = (score(&m16), score(&m8));
    println!("footprint: f32 {f_gt:.3}, int16 {q16_gt:.3}, int8 {q8_gt:.3} dB; rays as lines {line_gt:.3} dB");
    assert!(f_gt != line_gt, "the footprint changes the render");
    assert!(q16_gt >= f_gt - 0.1, "int16 loses {:.3} dB", f_gt - q16_gt);
    assert!(q8_gt >= f_gt - 0.5, "int8 loses {:.3} dB", f_gt - q8_gt);
}
