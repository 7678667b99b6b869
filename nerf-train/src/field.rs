//! The radiance field a run fits, as one part: the network's shape
//! ([`Mlp`]: the feature grid and the layers, forward and backward), its
//! parameters, their Adam state and their moving average. A step hands it
//! the batch's gradient ([`Field::apply`]); the model takes its average
//! ([`Field::model_params`]).

use crate::config::{OptimiserConfig, TrainConfig};
use crate::mlp::Mlp;
use crate::optim::adam::Adam;

/// The initialisation seed of network `k` (0 coarse, 1 fine) of a run seeded `seed`.
pub fn network_seed(seed: u64, k: usize) -> u64 {
    if k == 0 {
        seed
    } else {
        seed ^ crate::util::rng::stream::FINE_INIT
    }
}

/// A run's field: one network (a run with an occupancy or proposal grid)
/// or a coarse and a fine one of the same shape (the paper's two passes).
#[derive(Clone, Debug)]
pub struct Field {
    /// The networks' shape (from the run's configuration, [`TrainConfig::mlp`]).
    pub net: Mlp,
    /// The coarse network's parameters, then the fine one's, each in
    /// [`Mlp`]'s layout (a feature grid's table last).
    pub params: Vec<f32>,
    /// Adam's state for every parameter (a feature grid's table updated
    /// only where its gradient is not zero).
    pub adam: Adam,
    /// With [`OptimiserConfig::ema_decay`]: the moving average of
    /// `params` (as long as they, from the first step that updates them);
    /// empty otherwise and before that step.
    pub ema: Vec<f32>,
}

impl Field {
    /// A field initialised for a run of `cfg` seeded `seed`: the networks'
    /// density the same everywhere at `uniform_density` (1/world units; an
    /// unbounded scene's, [`Mlp::init_uniform_density`]) or, with `None`,
    /// [`Mlp::init`]'s; Adam's state zeroed, no average yet.
    ///
    /// # Panics
    /// `cfg` must pass [`TrainConfig::validate`].
    pub fn new(cfg: &TrainConfig, seed: u64, uniform_density: Option<f32>) -> Self {
        let net = cfg.mlp();
        let init = |seed| match uniform_density {
            Some(sigma) => net.init_uniform_density(seed, sigma),
            None => net.init(seed),
        };
        let mut params = init(network_seed(seed, 0));
        if cfg.sampling.n_fine.is_some() {
            params.extend(init(network_seed(seed, 1)));
        }
        let adam = Adam::new(params.len(), Self::table_values(&net, params.len()));
        Self { net, params, adam, ema: Vec::new() }
    }

    /// How many of `params` parameters are a feature grid's table: the last
    /// ones (a run with a feature grid has one network), none without one.
    ///
    /// # Panics
    /// If `params` is below `net.table` (the layers' parameters) in a network with a feature grid.
    pub fn table_values(net: &Mlp, params: usize) -> usize {
        if net.features.is_some() {
            params.checked_sub(net.table).expect("fewer parameters than the network's layers hold")
        } else {
            0
        }
    }

    /// The coarse (or only) network's parameters.
    pub fn coarse(&self) -> &[f32] {
        &self.params[..self.net.n_params]
    }

    /// The fine network's parameters, if the field has one.
    pub fn fine(&self) -> Option<&[f32]> {
        let n = self.net.n_params;
        (self.params.len() > n).then(|| &self.params[n..])
    }

    /// One optimiser step at learning rate `lr` with `opt`'s Adam settings
    /// and feature decay, from `grad` (as long as `params`; left zeroed),
    /// the `step`-th of the run (from 0). With `opt.ema_decay` b > 0 the
    /// average follows in the same sweep, `ema ← b'·ema + (1 − b')·params`
    /// with `b' = min(b, (1 + step)/(10 + step))`; the first step's average
    /// is a copy of the parameters.
    ///
    /// # Panics
    /// If `grad` does not hold as many values as `params`.
    pub fn apply(&mut self, grad: &mut [f32], lr: f32, opt: &OptimiserConfig, step: u64) {
        let decay = opt.ema_decay;
        let b = decay.min((1.0 + step as f32) / (10.0 + step as f32));
        let folded = decay > 0.0 && self.ema.len() == self.params.len();
        self.adam.update_averaged(
            &mut self.params,
            grad,
            lr,
            opt.beta1,
            opt.beta2,
            opt.eps,
            opt.feature_decay,
            folded.then_some((&mut self.ema[..], b)),
        );
        if decay > 0.0 && !folded {
            self.ema.clone_from(&self.params);
        }
    }

    /// The parameters a model takes: the average with `opt.ema_decay` once
    /// a step has made one, otherwise `None` (the parameters themselves).
    pub fn model_params(&self, opt: &OptimiserConfig) -> Option<&[f32]> {
        (opt.ema_decay > 0.0 && self.ema.len() == self.params.len()).then_some(&self.ema[..])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_pass_runs_hold_two_networks_and_grid_runs_one_with_its_table_sparse() {
        let two = Field::new(&TrainConfig::fast(), 5, None);
        let (c, f) = (two.coarse(), two.fine().expect("the fast preset has a fine network"));
        assert_eq!((c.len(), f.len()), (two.net.n_params, two.net.n_params));
        assert_ne!(c, f, "the fine network has a seed of its own");
        assert!(two.adam.steps.is_empty() && two.ema.is_empty());
        let one = Field::new(&TrainConfig::features(), 5, Some(0.1));
        assert!(one.fine().is_none());
        assert_eq!(one.adam.steps.len(), one.params.len() - one.net.table);
        assert!(!one.adam.steps.is_empty(), "the feature grid's table is updated where its gradient is not zero");
    }

    #[test]
    fn the_first_step_copies_the_parameters_into_the_average_and_later_steps_fold_them_in() {
        let cfg = TrainConfig::features();
        let mut field = Field::new(&cfg, 1, None);
        let mut grad: Vec<f32> = (0..field.params.len()).map(|i| ((i % 7) as f32 - 3.0) * 1e-3).collect();
        assert!(field.model_params(&cfg.optimiser).is_none());
        field.apply(&mut grad.clone(), 1e-2, &cfg.optimiser, 0);
        assert_eq!(field.model_params(&cfg.optimiser), Some(&field.params[..]));
        let before = field.ema.clone();
        field.apply(&mut grad, 1e-2, &cfg.optimiser, 1);
        assert!(grad.iter().all(|&g| g == 0.0), "the gradient is left zeroed");
        let b = cfg.optimiser.ema_decay.min(2.0 / 11.0);
        let want: Vec<f32> = before.iter().zip(&field.params).map(|(&a, &p)| a + (1.0 - b) * (p - a)).collect();
        assert_eq!(field.ema, want);
    }
}
