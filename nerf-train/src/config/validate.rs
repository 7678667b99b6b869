//! Which configurations train: every field in its range, and the fields
//! that constrain one another consistent.

use super::*;
use crate::error::ConfigError;

impl TrainConfig {
    /// Checks ranges; the message names the offending field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let t = self.topology();
        if self.model.depth == 0 || self.model.width == 0 || self.model.width > 256 || t.layer_count() > 24 {
            return Err(ConfigError::invalid("model.depth", "must be 1..=20 and model.width 1..=256"));
        }
        if self.model.view_dependent && (self.model.view_width == 0 || self.model.view_width > 256) {
            return Err(ConfigError::invalid("model.view_width", "must be 1..=256"));
        }
        if self.model.pos_freqs > 16 || self.model.dir_freqs > 16 {
            return Err(ConfigError::invalid("model.pos_freqs", "and model.dir_freqs must be at most 16"));
        }
        if self.model.skips.iter().any(|&s| s == 0 || s >= self.model.depth) {
            return Err(ConfigError::invalid("model.skips", "must name trunk layers 1..model.depth"));
        }
        let n_fine = self.sampling.n_fine.map_or(0, |n| n.get() as usize);
        // a model's fine pass draws from two bins of coarse weights: three samples
        let (least, most) = (if n_fine > 0 { 3 } else { 2 }, nerf_infer::format::max_coarse(n_fine));
        if !(least..=most).contains(&(self.sampling.n_coarse as usize)) || n_fine > nerf_infer::format::MAX_FINE {
            return Err(ConfigError::invalid(
                "sampling.n_coarse",
                "must be 2..=1024 (3..=256 with sampling.n_fine) and sampling.n_fine at most 256",
            ));
        }
        if self.sampling.n_main_render.is_some_and(|n| n.get() > 255) {
            return Err(ConfigError::invalid("sampling.n_main_render", "must be 0..=255"));
        }
        if let Some(res) = self.sampling.proposal_res {
            if res.get() > nerf_infer::proposal::MAX_PROPOSAL_RES || self.sampling.n_fine.is_some() {
                return Err(ConfigError::invalid(
                    "sampling.proposal_res",
                    "must be 0..=128, and 0 with sampling.n_fine",
                ));
            }
            if !(1..=255).contains(&self.sampling.n_main) || !(3..=256).contains(&self.sampling.n_coarse) {
                return Err(ConfigError::Combination {
                    fields: &["sampling.proposal_res", "sampling.n_main", "sampling.n_coarse"],
                    rule: "with a proposal grid, sampling.n_main must be 1..=255 and sampling.n_coarse 3..=256",
                });
            }
            if !(self.optimiser.proposal_lr.is_finite() && self.optimiser.proposal_lr > 0.0) {
                return Err(ConfigError::invalid(
                    "optimiser.proposal_lr",
                    format!("{} must be a finite rate > 0", self.optimiser.proposal_lr),
                ));
            }
        }
        if self.sampling.batch_rays == 0 || self.sampling.chunk_rays == 0 {
            return Err(ConfigError::invalid("sampling.batch_rays", "and sampling.chunk_rays must be positive"));
        }
        if self.sampling.batch_rays > MAX_BATCH_RAYS || self.sampling.chunk_rays > MAX_BATCH_RAYS {
            // activations kept for the backward pass: rays × samples × width × depth, f32, forward and gradient
            let samples = (self.sampling.n_coarse as usize + n_fine) as f64;
            let gb =
                self.sampling.batch_rays as f64 * samples * self.model.width as f64 * self.model.depth as f64 * 8.0
                    / 1e9;
            return Err(ConfigError::invalid(
                "sampling.batch_rays",
                format!(
                    "{} and sampling.chunk_rays {} must be at most {MAX_BATCH_RAYS} (this batch would hold about \
                 {gb:.0} GB of activations)",
                    self.sampling.batch_rays, self.sampling.chunk_rays
                ),
            ));
        }
        if !(self.loss.distortion.is_finite() && self.loss.distortion >= 0.0) {
            return Err(ConfigError::invalid(
                "loss.distortion",
                format!("{} must be a finite weight ≥ 0", self.loss.distortion),
            ));
        }
        if !(self.loss.near_gradient.is_finite() && self.loss.near_gradient >= 0.0) {
            return Err(ConfigError::invalid(
                "loss.near_gradient",
                format!("{} must be a finite distance ≥ 0", self.loss.near_gradient),
            ));
        }
        if !(0.0..1.0).contains(&self.loss.backward_transmittance) {
            return Err(ConfigError::invalid(
                "loss.backward_transmittance",
                format!("{} must be a transmittance in [0, 1)", self.loss.backward_transmittance),
            ));
        }
        if !(self.loss.density_l1.is_finite() && self.loss.density_l1 >= 0.0) {
            return Err(ConfigError::invalid(
                "loss.density_l1",
                format!("{} must be a finite weight ≥ 0", self.loss.density_l1),
            ));
        }
        if self.sampling.pixel_jitter && self.features.footprint && self.features.levels.is_some() {
            return Err(ConfigError::invalid(
                "sampling.pixel_jitter",
                "and features.footprint together spread each ray across its pixel twice",
            ));
        }
        if !(0.0..1.0).contains(&self.optimiser.ema_decay) {
            return Err(ConfigError::invalid(
                "optimiser.ema_decay",
                format!("{} must be a decay per step in [0, 1)", self.optimiser.ema_decay),
            ));
        }
        if !(0.0..1.0).contains(&self.features.footprint_from) {
            return Err(ConfigError::invalid(
                "features.footprint_from",
                format!("{} must be a share of the run in [0, 1)", self.features.footprint_from),
            ));
        }
        self.validate_optimiser()?;
        // every step scales the table by 1 − optimiser.lr·optimiser.feature_decay: it must stay in [0, 1]
        if !(self.optimiser.feature_decay >= 0.0 && self.optimiser.lr * self.optimiser.feature_decay <= 1.0) {
            return Err(ConfigError::invalid(
                "optimiser.feature_decay",
                format!(
                    "{} must be ≥ 0 and at most 1/optimiser.lr ({})",
                    self.optimiser.feature_decay,
                    1.0 / self.optimiser.lr
                ),
            ));
        }
        if !(0.0..=1.0).contains(&self.sampling.random_background) {
            return Err(ConfigError::invalid(
                "sampling.random_background",
                format!("{} must be a share of the rays in [0, 1]", self.sampling.random_background),
            ));
        }
        if let Some(res) = self.grid.res {
            if res.get() > nerf_infer::occupancy::MAX_GRID_RES {
                return Err(ConfigError::invalid("grid.res", "must be at most 256"));
            }
            if self.sampling.n_fine.is_some()
                || self.grid.every == 0
                || self.grid.alpha.is_nan()
                || self.grid.alpha <= 0.0
            {
                return Err(ConfigError::Combination {
                    fields: &["grid.res", "sampling.n_fine", "grid.every", "grid.alpha"],
                    rule: "an occupancy grid needs sampling.n_fine = 0, grid.every > 0 and grid.alpha > 0",
                });
            }
        }
        if let Some(levels) = self.features.levels {
            let f = self;
            let levels = levels.get() as usize;
            let dim = levels * f.features.width as usize;
            if levels > MAX_LEVELS || !(1..=8).contains(&f.features.width) || dim > MAX_FEATURES {
                return Err(ConfigError::invalid(
                    "features.levels",
                    "must be 1..=16, features.width 1..=8, their product at most 32",
                ));
            }
            if !(1..=MAX_LOG2_TABLE).contains(&f.features.log2_table) {
                return Err(ConfigError::invalid("features.log2_table", "must be 1..=22"));
            }
            if f.features.min_res == 0 || f.features.max_res < f.features.min_res || f.features.max_res > MAX_RES {
                return Err(ConfigError::Combination {
                    fields: &["features.min_res", "features.max_res"],
                    rule: "need 1 <= features.min_res <= features.max_res <= 4096",
                });
            }
            if f.sampling.n_fine.is_some() {
                return Err(ConfigError::Combination {
                    fields: &["features.levels", "sampling.n_fine"],
                    rule: "a feature grid needs one network (sampling.n_fine = 0)",
                });
            }
        }
        if self.loss.near_gradient > 0.0 && self.sampling.n_fine.is_some() {
            return Err(ConfigError::invalid("loss.near_gradient", "needs one network (sampling.n_fine = 0)"));
        }
        if self.per_photo.pose_refine && self.sampling.n_fine.is_some() {
            return Err(ConfigError::invalid("per_photo.pose_refine", "needs one network (sampling.n_fine = 0)"));
        }
        if !(self.per_photo.pose_lr.is_finite() && self.per_photo.pose_lr >= 0.0) {
            return Err(ConfigError::invalid(
                "per_photo.pose_lr",
                format!("must be finite and not negative, not {}", self.per_photo.pose_lr),
            ));
        }
        Ok(())
    }

    /// The optimiser's rates and decays, each named with its value and
    /// range when out of it (checked before anything that divides by one):
    /// a step size above 1 sends Adam's parameters to infinity within a
    /// few steps.
    fn validate_optimiser(&self) -> Result<(), ConfigError> {
        let o = &self.optimiser;
        let rate = |v: f32| v.is_finite() && v > 0.0 && v <= 1.0;
        let checks: [(&'static str, f32, bool, &str); 6] = [
            ("optimiser.lr", o.lr, rate(o.lr), "a step size in (0, 1]"),
            ("optimiser.lr_final_ratio", o.lr_final_ratio, rate(o.lr_final_ratio), "a share of optimiser.lr in (0, 1]"),
            ("optimiser.eps", o.eps, rate(o.eps), "in (0, 1]"),
            ("optimiser.beta1", o.beta1, (0.0..1.0).contains(&o.beta1), "a decay in [0, 1)"),
            ("optimiser.beta2", o.beta2, (0.0..1.0).contains(&o.beta2), "a decay in [0, 1)"),
            ("optimiser.proposal_lr", o.proposal_lr, rate(o.proposal_lr), "a step size in (0, 1]"),
        ];
        match checks.iter().find(|c| !c.2) {
            Some(&(name, v, _, range)) => {
                Err(ConfigError::invalid(name, format!("{} must be {range}", crate::error::number(v))))
            }
            None => Ok(()),
        }
    }
}
