//! Which configurations train: every field in its range, and the fields
//! that constrain one another consistent.

use super::*;
use crate::error::Error;

impl TrainConfig {
    /// Checks ranges; the message names the offending field.
    pub fn validate(&self) -> Result<(), Error> {
        let t = self.topology();
        if self.depth == 0 || self.width == 0 || self.width > 256 || t.layer_count() > 24 {
            return Err(Error::Config("depth must be 1..=20 and width 1..=256".into()));
        }
        if self.view_dependent && (self.view_width == 0 || self.view_width > 256) {
            return Err(Error::Config("view_width must be 1..=256".into()));
        }
        if self.pos_freqs > 16 || self.dir_freqs > 16 {
            return Err(Error::Config("pos_freqs and dir_freqs must be at most 16".into()));
        }
        if self.skips.iter().any(|&s| s == 0 || s >= self.depth) {
            return Err(Error::Config("skips must name trunk layers 1..depth".into()));
        }
        let most = nerf_infer::format::max_coarse(self.n_fine as usize);
        if !(2..=most).contains(&(self.n_coarse as usize)) || self.n_fine as usize > nerf_infer::format::MAX_FINE {
            return Err(Error::Config("n_coarse must be 2..=1024 (2..=256 with n_fine) and n_fine at most 256".into()));
        }
        if self.proposal_res > 0 {
            if self.proposal_res > nerf_infer::proposal::MAX_PROPOSAL_RES || self.n_fine > 0 {
                return Err(Error::Config("proposal_res must be 0..=128, and 0 with n_fine".into()));
            }
            if !(1..=255).contains(&self.n_main) || !(3..=256).contains(&self.n_coarse) {
                return Err(Error::Config("with a proposal grid, n_main must be 1..=255 and n_coarse 3..=256".into()));
            }
            if !(self.proposal_lr.is_finite() && self.proposal_lr > 0.0) {
                return Err(Error::Config(format!("proposal_lr {} must be a finite rate > 0", self.proposal_lr)));
            }
        }
        if self.batch_rays == 0 || self.chunk_rays == 0 {
            return Err(Error::Config("batch_rays and chunk_rays must be positive".into()));
        }
        if self.batch_rays > MAX_BATCH_RAYS || self.chunk_rays > MAX_BATCH_RAYS {
            // activations kept for the backward pass: rays × samples × width × depth, f32, forward and gradient
            let samples = (self.n_coarse + self.n_fine) as f64;
            let gb = self.batch_rays as f64 * samples * self.width as f64 * self.depth as f64 * 8.0 / 1e9;
            return Err(Error::Config(format!(
                "batch_rays {} and chunk_rays {} must be at most {MAX_BATCH_RAYS} (this batch would hold about \
                 {gb:.0} GB of activations)",
                self.batch_rays, self.chunk_rays
            )));
        }
        if !(self.distortion.is_finite() && self.distortion >= 0.0) {
            return Err(Error::Config(format!("distortion {} must be a finite weight ≥ 0", self.distortion)));
        }
        if !(self.density_l1.is_finite() && self.density_l1 >= 0.0) {
            return Err(Error::Config(format!("density_l1 {} must be a finite weight ≥ 0", self.density_l1)));
        }
        if self.pixel_jitter && self.footprint && self.feature_levels > 0 {
            return Err(Error::Config(
                "pixel_jitter and footprint together spread each ray across its pixel twice".into(),
            ));
        }
        if !(0.0..1.0).contains(&self.ema_decay) {
            return Err(Error::Config(format!("ema_decay {} must be a decay per step in [0, 1)", self.ema_decay)));
        }
        if !(0.0..1.0).contains(&self.footprint_from) {
            return Err(Error::Config(format!(
                "footprint_from {} must be a share of the run in [0, 1)",
                self.footprint_from
            )));
        }
        // every step scales the table by 1 − lr·feature_decay: it must stay in [0, 1]
        if !(self.feature_decay >= 0.0 && self.lr * self.feature_decay <= 1.0) {
            return Err(Error::Config(format!(
                "feature_decay {} must be ≥ 0 and at most 1/lr ({})",
                self.feature_decay,
                1.0 / self.lr
            )));
        }
        if !(0.0..=1.0).contains(&self.random_background) {
            return Err(Error::Config(format!(
                "random_background {} must be a share of the rays in [0, 1]",
                self.random_background
            )));
        }
        if self.grid_res > nerf_infer::occupancy::MAX_GRID_RES {
            return Err(Error::Config("grid_res must be at most 256".into()));
        }
        if self.grid_res > 0
            && (self.n_fine > 0 || self.grid_every == 0 || self.grid_alpha.is_nan() || self.grid_alpha <= 0.0)
        {
            return Err(Error::Config("an occupancy grid needs n_fine = 0, grid_every > 0 and grid_alpha > 0".into()));
        }
        if self.feature_levels > 0 {
            let f = self;
            let dim = f.feature_levels as usize * f.feature_width as usize;
            if f.feature_levels as usize > MAX_LEVELS || !(1..=8).contains(&f.feature_width) || dim > MAX_FEATURES {
                return Err(Error::Config(
                    "feature_levels must be 1..=16, feature_width 1..=8, their product at most 32".into(),
                ));
            }
            if !(1..=MAX_LOG2_TABLE).contains(&f.feature_log2_table) {
                return Err(Error::Config("feature_log2_table must be 1..=22".into()));
            }
            if f.feature_min_res == 0 || f.feature_max_res < f.feature_min_res || f.feature_max_res > MAX_RES {
                return Err(Error::Config("need 1 <= feature_min_res <= feature_max_res <= 4096".into()));
            }
            if f.n_fine > 0 {
                return Err(Error::Config("a feature grid needs one network (n_fine = 0)".into()));
            }
        }
        let pos = |v: f32| v.is_finite() && v > 0.0;
        if !pos(self.lr)
            || !pos(self.lr_final_ratio)
            || !pos(self.eps)
            || !(0.0..1.0).contains(&self.beta1)
            || !(0.0..1.0).contains(&self.beta2)
        {
            return Err(Error::Config("lr, lr_final_ratio, eps must be positive and betas in [0, 1)".into()));
        }
        Ok(())
    }
}
