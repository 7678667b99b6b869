//! The run's time report: each stage's milliseconds per step and the
//! layers' throughput, for the log and the last line.

use super::Window;
use crate::mlp::Mlp;
use crate::util::timing::StepTimes;

/// Milliseconds per step of each stage of [`StepTimes`], averaged over `steps`.
pub fn stage_ms(t: &StepTimes, steps: u64) -> serde_json::Value {
    let per = 1e3 / steps.max(1) as f64;
    serde_json::Value::Object(t.stages().iter().map(|&(k, v)| (k.to_string(), (v * per).into())).collect())
}

/// GFLOP/s per thread of the network's layers over the steps of `w`,
/// forward (2 flops per multiply-accumulate, over its network
/// evaluations) and backward (4: the input's and the weights' gradients,
/// over the evaluations the backward pass took).
pub fn mlp_gflops(w: &Window, mlp: &Mlp) -> serde_json::Value {
    let gflops = |samples: usize| samples as f64 * mlp.macs_per_sample() as f64 / 1e9;
    serde_json::json!({
        "forward": 2.0 * gflops(w.samples) / w.times.forward.max(1e-9),
        "backward": 4.0 * gflops(w.backward_samples) / w.times.backward.max(1e-9),
    })
}

/// One line on where the time of `w`'s `steps` went: each wall stage's
/// share of the steps, the chunks' thread time split, the share of the
/// network evaluations the backward pass took, and the layers' GFLOP/s
/// per thread.
pub fn time_summary(w: &Window, steps: u64, mlp: &Mlp) -> String {
    let t = &w.times;
    let wall = t.wall().max(1e-9);
    let thread = t.thread().max(1e-9);
    let share = |v: f64, of: f64| format!("{:.0} %", 100.0 * v / of);
    let stages: Vec<String> = t.wall_stages().iter().map(|&(k, v)| format!("{k} {}", share(v, wall))).collect();
    let split: Vec<String> = t.thread_stages().iter().map(|&(k, v)| format!("{k} {}", share(v, thread))).collect();
    let g = mlp_gflops(w, mlp);
    format!(
        "time per step {:.2} ms over {steps} steps: {}; chunks' thread time: {}; backward on {} of the samples; \
         layers {:.1} GFLOP/s forward, {:.1} backward per thread",
        1e3 * wall / steps.max(1) as f64,
        stages.join(", "),
        split.join(", "),
        share(w.backward_samples as f64, w.samples.max(1) as f64),
        g["forward"].as_f64().unwrap_or(0.0),
        g["backward"].as_f64().unwrap_or(0.0),
    )
}
