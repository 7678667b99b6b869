//! The moving average of the parameters that a run's model takes
//! ([`OptimiserConfig::ema_decay`](crate::config::OptimiserConfig::ema_decay)).

use super::*;

impl Trainer {
    /// The run as its model takes it: with a parameters' average
    /// ([`OptimiserConfig::ema_decay`](crate::config::OptimiserConfig::ema_decay)), a copy holding the average as its
    /// parameters and its occupancy grid (once the run has refreshed it)
    /// refreshed once more, from the average's density; otherwise the run
    /// itself.
    pub fn averaged(&self) -> std::borrow::Cow<'_, Trainer> {
        let Some(average) = self.field.model_params(&self.cfg.optimiser) else {
            return std::borrow::Cow::Borrowed(self);
        };
        let mut t = self.clone();
        t.field.params.copy_from_slice(average);
        if t.sampler.occupancy.as_ref().is_some_and(|g| g.updates > 0) {
            t.update_grid();
        }
        std::borrow::Cow::Owned(t)
    }
}
