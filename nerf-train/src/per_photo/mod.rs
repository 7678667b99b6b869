//! What a run learns for each training photo: its colour correction
//! ([`appearance`]) and its pose correction ([`pose`]), each a
//! [`PerPhoto`] of its own width.

use crate::optim::adam::Adam;
use serde::{Deserialize, Serialize};

pub mod appearance;
pub mod pose;

/// `N` values fitted per training photo, photo after photo in the
/// dataset's order of training views, and their Adam state:
/// [`appearance::Appearance`] (12 a photo) and [`pose::Poses`] (6).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PerPhoto<const N: usize> {
    /// `N` values per photo.
    pub params: Vec<f32>,
    /// Their Adam state.
    pub adam: Adam,
}

impl<const N: usize> PerPhoto<N> {
    /// `start` for each of `photos` photos.
    pub fn filled(photos: usize, start: [f32; N]) -> Self {
        let params: Vec<f32> = start.iter().copied().cycle().take(photos * N).collect();
        let adam = Adam::new(params.len(), 0);
        Self { params, adam }
    }

    /// Photos held.
    pub fn photos(&self) -> usize {
        self.params.len() / N
    }

    /// Whether the state is whole: `N` values per photo and the
    /// optimiser's moments for each.
    pub fn is_consistent(&self) -> bool {
        let n = self.params.len();
        n.is_multiple_of(N) && self.adam.m.len() == n && self.adam.v.len() == n && self.adam.steps.is_empty()
    }

    /// Photo `photo`'s `N` values.
    pub fn row(&self, photo: usize) -> &[f32] {
        &self.params[photo * N..(photo + 1) * N]
    }

    /// One Adam step at learning rate `lr` on `grad` (as `params`; left
    /// zeroed).
    fn adam_step(&mut self, grad: &mut [f32], lr: f32, beta1: f32, beta2: f32, eps: f32) {
        self.adam.update(&mut self.params, grad, lr, beta1, beta2, eps, 0.0);
    }
}
