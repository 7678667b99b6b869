//! Which configurations train: every field in its range, and the fields
//! that constrain one another consistent.

use super::*;
use crate::error::Error;

impl TrainConfig {
    /// Checks ranges; the message names the offending field.
    pub fn validate(&self) -> Result<(), Error> {
        let t = self.topology();
        if self.model.depth == 0 || self.model.width == 0 || self.model.width > 256 || t.layer_count() > 24 {
            return Err(Error::Config("model.depth must be 1..=20 and model.width 1..=256".into()));
        }
        if self.model.view_dependent && (self.model.view_width == 0 || self.model.view_width > 256) {
            return Err(Error::Config("model.view_width must be 1..=256".into()));
        }
        if self.model.pos_freqs > 16 || self.model.dir_freqs > 16 {
            return Err(Error::Config("model.pos_freqs and model.dir_freqs must be at most 16".into()));
        }
        if self.model.skips.iter().any(|&s| s == 0 || s >= self.model.depth) {
            return Err(Error::Config("model.skips must name trunk layers 1..model.depth".into()));
        }
        let n_fine = self.sampling.n_fine.map_or(0, |n| n.get() as usize);
        let most = nerf_infer::format::max_coarse(n_fine);
        if !(2..=most).contains(&(self.sampling.n_coarse as usize)) || n_fine > nerf_infer::format::MAX_FINE {
            return Err(Error::Config(
                "sampling.n_coarse must be 2..=1024 (2..=256 with sampling.n_fine) and sampling.n_fine at most 256"
                    .into(),
            ));
        }
        if self.sampling.n_main_render.is_some_and(|n| n.get() > 255) {
            return Err(Error::Config("sampling.n_main_render must be 0..=255".into()));
        }
        if let Some(res) = self.sampling.proposal_res {
            if res.get() > nerf_infer::proposal::MAX_PROPOSAL_RES || self.sampling.n_fine.is_some() {
                return Err(Error::Config("sampling.proposal_res must be 0..=128, and 0 with sampling.n_fine".into()));
            }
            if !(1..=255).contains(&self.sampling.n_main) || !(3..=256).contains(&self.sampling.n_coarse) {
                return Err(Error::Config(
                    "with a proposal grid, sampling.n_main must be 1..=255 and sampling.n_coarse 3..=256".into(),
                ));
            }
            if !(self.optimiser.proposal_lr.is_finite() && self.optimiser.proposal_lr > 0.0) {
                return Err(Error::Config(format!(
                    "optimiser.proposal_lr {} must be a finite rate > 0",
                    self.optimiser.proposal_lr
                )));
            }
        }
        if self.sampling.batch_rays == 0 || self.sampling.chunk_rays == 0 {
            return Err(Error::Config("sampling.batch_rays and sampling.chunk_rays must be positive".into()));
        }
        if self.sampling.batch_rays > MAX_BATCH_RAYS || self.sampling.chunk_rays > MAX_BATCH_RAYS {
            // activations kept for the backward pass: rays × samples × width × depth, f32, forward and gradient
            let samples = (self.sampling.n_coarse as usize + n_fine) as f64;
            let gb =
                self.sampling.batch_rays as f64 * samples * self.model.width as f64 * self.model.depth as f64 * 8.0
                    / 1e9;
            return Err(Error::Config(format!(
                "sampling.batch_rays {} and sampling.chunk_rays {} must be at most {MAX_BATCH_RAYS} (this batch would hold about \
                 {gb:.0} GB of activations)",
                self.sampling.batch_rays, self.sampling.chunk_rays
            )));
        }
        if !(self.loss.distortion.is_finite() && self.loss.distortion >= 0.0) {
            return Err(Error::Config(format!("loss.distortion {} must be a finite weight ≥ 0", self.loss.distortion)));
        }
        if !(self.loss.near_gradient.is_finite() && self.loss.near_gradient >= 0.0) {
            return Err(Error::Config(format!(
                "loss.near_gradient {} must be a finite distance ≥ 0",
                self.loss.near_gradient
            )));
        }
        if !(self.loss.density_l1.is_finite() && self.loss.density_l1 >= 0.0) {
            return Err(Error::Config(format!("loss.density_l1 {} must be a finite weight ≥ 0", self.loss.density_l1)));
        }
        if self.sampling.pixel_jitter && self.features.footprint && self.features.levels.is_some() {
            return Err(Error::Config(
                "sampling.pixel_jitter and features.footprint together spread each ray across its pixel twice".into(),
            ));
        }
        if !(0.0..1.0).contains(&self.optimiser.ema_decay) {
            return Err(Error::Config(format!(
                "optimiser.ema_decay {} must be a decay per step in [0, 1)",
                self.optimiser.ema_decay
            )));
        }
        if !(0.0..1.0).contains(&self.features.footprint_from) {
            return Err(Error::Config(format!(
                "features.footprint_from {} must be a share of the run in [0, 1)",
                self.features.footprint_from
            )));
        }
        self.validate_optimiser()?;
        // every step scales the table by 1 − optimiser.lr·optimiser.feature_decay: it must stay in [0, 1]
        if !(self.optimiser.feature_decay >= 0.0 && self.optimiser.lr * self.optimiser.feature_decay <= 1.0) {
            return Err(Error::Config(format!(
                "optimiser.feature_decay {} must be ≥ 0 and at most 1/optimiser.lr ({})",
                self.optimiser.feature_decay,
                1.0 / self.optimiser.lr
            )));
        }
        if !(0.0..=1.0).contains(&self.sampling.random_background) {
            return Err(Error::Config(format!(
                "sampling.random_background {} must be a share of the rays in [0, 1]",
                self.sampling.random_background
            )));
        }
        if let Some(res) = self.grid.res {
            if res.get() > nerf_infer::occupancy::MAX_GRID_RES {
                return Err(Error::Config("grid.res must be at most 256".into()));
            }
            if self.sampling.n_fine.is_some()
                || self.grid.every == 0
                || self.grid.alpha.is_nan()
                || self.grid.alpha <= 0.0
            {
                return Err(Error::Config(
                    "an occupancy grid needs sampling.n_fine = 0, grid.every > 0 and grid.alpha > 0".into(),
                ));
            }
        }
        if let Some(levels) = self.features.levels {
            let f = self;
            let levels = levels.get() as usize;
            let dim = levels * f.features.width as usize;
            if levels > MAX_LEVELS || !(1..=8).contains(&f.features.width) || dim > MAX_FEATURES {
                return Err(Error::Config(
                    "features.levels must be 1..=16, features.width 1..=8, their product at most 32".into(),
                ));
            }
            if !(1..=MAX_LOG2_TABLE).contains(&f.features.log2_table) {
                return Err(Error::Config("features.log2_table must be 1..=22".into()));
            }
            if f.features.min_res == 0 || f.features.max_res < f.features.min_res || f.features.max_res > MAX_RES {
                return Err(Error::Config("need 1 <= features.min_res <= features.max_res <= 4096".into()));
            }
            if f.sampling.n_fine.is_some() {
                return Err(Error::Config("a feature grid needs one network (sampling.n_fine = 0)".into()));
            }
        }
        if self.loss.near_gradient > 0.0 && self.sampling.n_fine.is_some() {
            return Err(Error::Config("loss.near_gradient needs one network (sampling.n_fine = 0)".into()));
        }
        if self.per_photo.pose_refine && self.sampling.n_fine.is_some() {
            return Err(Error::Config("per_photo.pose_refine needs one network (sampling.n_fine = 0)".into()));
        }
        if !(self.per_photo.pose_lr.is_finite() && self.per_photo.pose_lr >= 0.0) {
            return Err(Error::Config(format!(
                "per_photo.pose_lr must be finite and not negative, not {}",
                self.per_photo.pose_lr
            )));
        }
        Ok(())
    }

    /// The optimiser's rates and decays, each named with its value and
    /// range when out of it (checked before anything that divides by one):
    /// a step size above 1 sends Adam's parameters to infinity within a
    /// few steps.
    fn validate_optimiser(&self) -> Result<(), Error> {
        let o = &self.optimiser;
        let rate = |v: f32| v.is_finite() && v > 0.0 && v <= 1.0;
        let checks: [(&str, f32, bool, &str); 6] = [
            ("lr", o.lr, rate(o.lr), "a step size in (0, 1]"),
            ("lr_final_ratio", o.lr_final_ratio, rate(o.lr_final_ratio), "a share of optimiser.lr in (0, 1]"),
            ("eps", o.eps, rate(o.eps), "in (0, 1]"),
            ("beta1", o.beta1, (0.0..1.0).contains(&o.beta1), "a decay in [0, 1)"),
            ("beta2", o.beta2, (0.0..1.0).contains(&o.beta2), "a decay in [0, 1)"),
            ("proposal_lr", o.proposal_lr, rate(o.proposal_lr), "a step size in (0, 1]"),
        ];
        match checks.iter().find(|c| !c.2) {
            Some((name, v, _, range)) => {
                Err(Error::Config(format!("optimiser.{name} {} must be {range}", crate::error::number(*v))))
            }
            None => Ok(()),
        }
    }
}
