//! Where a training step's time goes: the stages of
//! [`crate::train::Trainer::train_step`] timed with the monotonic clock.

use std::time::Instant;

/// Wall-clock stages of a step, first in [`StepTimes::stages`]; as many
/// thread stages follow.
const WALL_STAGES: usize = 5;

/// Seconds spent in each stage of training steps (one step, or summed over
/// several with [`StepTimes::add`]).
///
/// `grid`, `draw`, `chunks`, `scatter` and `adam` are wall-clock stages,
/// one after the other; they add up to the step. `sample`, `encode`,
/// `forward`, `composite` and `backward` split `chunks` in thread time
/// summed over the threads that ran it: on `N` busy threads they add up to
/// about `N × chunks`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepTimes {
    /// Wall: the occupancy grid refreshed from the density (every
    /// `grid.every` steps).
    pub grid: f64,
    /// Wall: the batch of rays drawn.
    pub draw: f64,
    /// Wall: forward and backward of every chunk of rays, in parallel,
    /// with the threads' layer gradients summed.
    pub chunks: f64,
    /// Wall: the feature table's gradient scattered from the chunks.
    pub scatter: f64,
    /// Wall: the Adam update of every parameter (and the parameters' average, `optimiser.ema_decay`).
    pub adam: f64,
    /// Thread: samples along the rays and the occupancy tests.
    pub sample: f64,
    /// Thread: the positions' encoding (γ and the feature-grid lookups).
    pub encode: f64,
    /// Thread: the network's layers, forward.
    pub forward: f64,
    /// Thread: the volume-rendering quadrature and the loss's gradient.
    pub composite: f64,
    /// Thread: the network's backward pass (layers and the encoding's
    /// input gradient).
    pub backward: f64,
}

impl StepTimes {
    /// Adds `o`'s seconds, stage by stage.
    pub fn add(&mut self, o: &StepTimes) {
        for (a, b) in self.stages_mut().into_iter().zip(o.stages()) {
            *a += b.1;
        }
    }

    /// Every stage with its name, wall stages first.
    pub fn stages(&self) -> [(&'static str, f64); 10] {
        [
            ("grid", self.grid),
            ("draw", self.draw),
            ("chunks", self.chunks),
            ("scatter", self.scatter),
            ("adam", self.adam),
            ("sample", self.sample),
            ("encode", self.encode),
            ("forward", self.forward),
            ("composite", self.composite),
            ("backward", self.backward),
        ]
    }

    fn stages_mut(&mut self) -> [&mut f64; 10] {
        [
            &mut self.grid,
            &mut self.draw,
            &mut self.chunks,
            &mut self.scatter,
            &mut self.adam,
            &mut self.sample,
            &mut self.encode,
            &mut self.forward,
            &mut self.composite,
            &mut self.backward,
        ]
    }

    /// The wall-clock stages with their names (the first of [`StepTimes::stages`]).
    pub fn wall_stages(&self) -> [(&'static str, f64); WALL_STAGES] {
        let s = self.stages();
        std::array::from_fn(|i| s[i])
    }

    /// The thread stages with their names (the rest of [`StepTimes::stages`]).
    pub fn thread_stages(&self) -> [(&'static str, f64); WALL_STAGES] {
        let s = self.stages();
        std::array::from_fn(|i| s[WALL_STAGES + i])
    }

    /// The wall-clock stages' sum, seconds.
    pub fn wall(&self) -> f64 {
        self.wall_stages().iter().map(|s| s.1).sum()
    }

    /// The thread stages' sum, seconds of all threads.
    pub fn thread(&self) -> f64 {
        self.thread_stages().iter().map(|s| s.1).sum()
    }
}

/// Runs `f` and adds its duration to `*secs`.
pub fn timed<T>(secs: &mut f64, f: impl FnOnce() -> T) -> T {
    let t = Instant::now();
    let out = f();
    *secs += t.elapsed().as_secs_f64();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn add_sums_stage_by_stage_and_wall_counts_the_wall_stages_only() {
        let a = StepTimes { grid: 1.0, chunks: 2.0, adam: 0.5, forward: 3.0, ..Default::default() };
        let mut b = StepTimes { draw: 0.25, chunks: 1.0, backward: 4.0, ..Default::default() };
        b.add(&a);
        assert_eq!(
            b,
            StepTimes {
                grid: 1.0,
                draw: 0.25,
                chunks: 3.0,
                adam: 0.5,
                forward: 3.0,
                backward: 4.0,
                ..Default::default()
            }
        );
        assert_eq!(b.wall(), 4.75);
        assert_eq!(b.thread(), 7.0);
        assert_eq!(b.wall_stages().map(|s| s.0), ["grid", "draw", "chunks", "scatter", "adam"]);
        assert_eq!(b.thread_stages().map(|s| s.0), ["sample", "encode", "forward", "composite", "backward"]);
        assert_eq!(b.stages().map(|s| s.0)[2], "chunks");
    }
}
