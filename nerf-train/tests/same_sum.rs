//! A step's result depends on the batch alone: the same parameters from
//! one thread, from several, and from threads that share the cores with a
//! busy process (the gradient's groups are summed in a fixed order).

use nerf_train::config::Preset;
use nerf_train::dataset::synthetic::{write_blender, write_llff, SceneSpec};
use nerf_train::dataset::{self, Dataset, LoadOptions, Split};
use nerf_train::run::{Budget, Fit, Run};
use std::sync::atomic::{AtomicBool, Ordering};

/// The parameters after `steps` steps of the default, seed 5, on `threads` threads.
fn trained(data: &Dataset, steps: u64, threads: usize) -> Vec<u32> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| {
        let (mut run, _) =
            Run::fitted(&Preset::default().config(), Fit::ALL, data, 1, 5, Budget::Steps(steps)).unwrap();
        run.train(&mut ()).unwrap();
        run.trainer.field.params.iter().map(|p| p.to_bits()).collect()
    })
}

#[test]
fn a_run_takes_the_same_steps_on_any_threads_and_beside_a_busy_process() {
    let dir = std::env::temp_dir().join(format!("nerf-train-same-sum-{}", std::process::id()));
    let spec = SceneSpec { size: 16, train: 6, val: 0, test: 0 };
    // an object scene (occupancy grid) and a forward-facing one (proposal grid, distortion loss)
    write_blender(&dir.join("blender"), spec).unwrap();
    write_llff(&dir.join("llff"), SceneSpec { train: 8, ..spec }).unwrap();
    for name in ["blender", "llff"] {
        let data = dataset::load(&dir.join(name), Split::Train, LoadOptions::default()).unwrap();
        let one = trained(&data, 4, 1);
        assert!(trained(&data, 4, 3) == one, "{name}: three threads step otherwise than one");
        // two threads that keep both cores busy while the run trains on two more
        let stop = AtomicBool::new(false);
        let busy = std::thread::scope(|s| {
            for _ in 0..2 {
                s.spawn(|| {
                    let mut x = 1u64;
                    while !stop.load(Ordering::Relaxed) {
                        x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
                    }
                });
            }
            let params = trained(&data, 4, 2);
            stop.store(true, Ordering::Relaxed);
            params
        });
        assert!(busy == one, "{name}: beside a busy process the run steps otherwise");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
