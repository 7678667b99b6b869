//! The run's time report: each stage's milliseconds per step and the
//! layers' throughput, for the log and the last line.

use crate::mlp::Mlp;
use crate::util::timing::StepTimes;

/// Milliseconds per step of each stage of [`StepTimes`], averaged over `steps`.
pub fn stage_ms(t: &StepTimes, steps: u64) -> serde_json::Value {
    let per = 1e3 / steps.max(1) as f64;
    serde_json::Value::Object(t.stages().iter().map(|&(k, v)| (k.to_string(), (v * per).into())).collect())
}

/// GFLOP/s per thread of the network's layers, forward (2 flops per
/// multiply-accumulate) and backward (4: the input's and the weights'
/// gradients), over `samples` network evaluations.
pub fn mlp_gflops(t: &StepTimes, samples: usize, mlp: &Mlp) -> serde_json::Value {
    let flops = samples as f64 * mlp.macs_per_sample() as f64 / 1e9;
    serde_json::json!({
        "forward": 2.0 * flops / t.forward.max(1e-9),
        "backward": 4.0 * flops / t.backward.max(1e-9),
    })
}

/// One line on where the run's time went: each wall stage's share of the
/// steps, the chunks' thread time split, and the layers' GFLOP/s per thread.
pub fn time_summary(t: &StepTimes, steps: u64, samples: usize, mlp: &Mlp) -> String {
    let wall = t.wall().max(1e-9);
    let thread = t.thread().max(1e-9);
    let share = |v: f64, of: f64| format!("{:.0} %", 100.0 * v / of);
    let stages: Vec<String> = t.wall_stages().iter().map(|&(k, v)| format!("{k} {}", share(v, wall))).collect();
    let split: Vec<String> = t.thread_stages().iter().map(|&(k, v)| format!("{k} {}", share(v, thread))).collect();
    let g = mlp_gflops(t, samples, mlp);
    format!(
        "time per step {:.2} ms over {steps} steps: {}; chunks' thread time: {}; layers {:.1} GFLOP/s forward, {:.1} \
         backward per thread",
        1e3 * wall / steps.max(1) as f64,
        stages.join(", "),
        split.join(", "),
        g["forward"].as_f64().unwrap_or(0.0),
        g["backward"].as_f64().unwrap_or(0.0),
    )
}
