//! The moving average of the parameters that a run's model takes
//! ([`OptimiserConfig::ema_decay`](crate::config::OptimiserConfig::ema_decay)).

use super::*;

/// Folds `params` into their moving average `ema` with decay `b`:
/// `ema ← b·ema + (1 − b)·params`, or a copy of `params` when `ema` does
/// not hold as many (the first step).
pub(super) fn average_into(ema: &mut Vec<f32>, params: &[f32], b: f32) {
    if ema.len() != params.len() {
        ema.clear();
        ema.extend_from_slice(params);
        return;
    }
    ema.iter_mut().zip(params).for_each(|(a, &p)| *a += (1.0 - b) * (p - *a));
}

impl Trainer {
    /// The run as its model takes it: with a parameters' average
    /// ([`OptimiserConfig::ema_decay`](crate::config::OptimiserConfig::ema_decay)), a copy holding the average as its
    /// parameters and its occupancy grid (once the run has refreshed it)
    /// refreshed once more, from the average's density; otherwise the run
    /// itself.
    pub fn averaged(&self) -> std::borrow::Cow<'_, Trainer> {
        if self.cfg.optimiser.ema_decay <= 0.0 || self.ema.len() != self.params.len() {
            return std::borrow::Cow::Borrowed(self);
        }
        let mut t = self.clone();
        t.params.clone_from(&self.ema);
        if t.grid.as_ref().is_some_and(|g| g.updates > 0) {
            t.update_grid();
        }
        std::borrow::Cow::Owned(t)
    }
}
