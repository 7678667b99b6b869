//! Gradient buffers reused from step to step.

use super::*;

/// Zeroed gradient buffers, chunks' grid-value gradients and groups'
/// working memory reused from step to step: a feature grid's table makes
/// each gradient megabytes, a chunk's corners hundreds of kilobytes, and
/// fresh ones cost page faults.
#[derive(Default)]
pub(super) struct GradPool(
    std::sync::Mutex<Vec<Vec<f32>>>,
    std::sync::Mutex<Vec<GridGrad>>,
    /// Each chunk's proposal-grid gradient.
    pub(super) std::sync::Mutex<PropGrads>,
    std::sync::Mutex<Vec<Workspace>>,
);

/// Each chunk's proposal-grid gradient, (cell, value) pairs, under the
/// chunk's key (summed in key order: the same sum whatever the threads).
pub(super) type PropGrads = Vec<(u32, Vec<(u32, f32)>)>;

impl Clone for GradPool {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for GradPool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("GradPool")
    }
}

impl GradPool {
    /// A zeroed buffer of `n` values.
    pub(super) fn take(&self, n: usize) -> Vec<f32> {
        let found = |p: &mut Vec<Vec<f32>>| p.iter().position(|v| v.len() == n).map(|i| p.swap_remove(i));
        self.0.lock().map(|mut p| found(&mut p)).unwrap_or(None).unwrap_or_else(|| vec![0.0; n])
    }
    /// Returns a buffer (zeroed here) for later steps.
    pub(super) fn give(&self, mut v: Vec<f32>) {
        v.par_chunks_mut(1 << 16).for_each(|b| b.fill(0.0));
        self.give_zeroed(v);
    }
    /// Returns a buffer whose values are all zero (as [`crate::optim::Adam`]
    /// leaves a gradient) for later steps.
    pub(super) fn give_zeroed(&self, v: Vec<f32>) {
        debug_assert!(v.iter().all(|&x| x == 0.0), "a gradient buffer returned with values in it");
        if let Ok(mut p) = self.0.lock() {
            p.push(v);
        }
    }
    /// A chunk's grid-value gradient whose buffers a forward pass may reuse.
    pub(super) fn take_grid(&self) -> GridGrad {
        self.1.lock().map(|mut p| p.pop()).unwrap_or(None).unwrap_or_default()
    }
    /// A group's working memory, its buffers sized by earlier steps (its
    /// photos' gradients empty).
    pub(super) fn take_workspace(&self) -> Workspace {
        self.3.lock().map(|mut p| p.pop()).unwrap_or(None).unwrap_or_default()
    }
    /// Returns a group's working memory for later groups.
    pub(super) fn give_workspace(&self, ws: Workspace) {
        if let Ok(mut p) = self.3.lock() {
            p.push(ws);
        }
    }
    /// Returns grid-value gradients for later chunks.
    pub(super) fn give_grids(&self, g: Vec<GridGrad>) {
        if let Ok(mut p) = self.1.lock() {
            p.extend(g);
        }
    }
}
