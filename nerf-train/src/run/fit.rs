//! The choices a run makes for its data: the proposal grid of open scenes,
//! the feature grid and samples sized to what the photos resolve, the
//! distortion loss and the render sample count that go with the proposal
//! grid. `nerf train` makes each one unless its `--config` names the field.

use crate::config::{json, TrainConfig};
use crate::dataset::Dataset;
use crate::error::{ConfigError, Result};

/// Which of the data-dependent choices a run makes ([`Fit::ALL`]: every
/// one, as `nerf train` does for a preset). A field a configuration file
/// names is the user's choice, and its flag is off ([`Fit::unless_named`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fit {
    /// Size the feature grid to the photos ([`TrainConfig::fit_features_to`]).
    pub features: bool,
    /// Give a grid sized to the photos [`TrainConfig::SIZED_LEVELS`]
    /// levels: in a forward-facing scene, and in an object scene where the
    /// configuration's levels would be 2× apart or more.
    pub levels: bool,
    /// Set the samples per ray for the photos ([`TrainConfig::fit_samples_to`]),
    /// or to [`TrainConfig::PROPOSAL_COARSE`] where a proposal grid is
    /// turned on.
    pub samples: bool,
    /// Place the network's samples with a proposal grid in unbounded and
    /// forward-facing scenes ([`TrainConfig::PROPOSAL_RES`]).
    pub proposal: bool,
    /// Turn the distortion loss on ([`TrainConfig::PROPOSAL_DISTORTION`])
    /// where the proposal grid is turned on.
    pub distortion: bool,
    /// Render at [`TrainConfig::PROPOSAL_RENDER_MAIN`] network samples
    /// where the proposal grid is turned on in an unbounded scene (a
    /// forward-facing one renders at the samples it trains with).
    pub render: bool,
}

impl Fit {
    /// Every choice made for the data.
    pub const ALL: Fit =
        Fit { features: true, levels: true, samples: true, proposal: true, distortion: true, render: true };

    /// For a configuration given whole, as [`TrainConfig`] rather than a
    /// preset: its feature grid (levels included) and samples kept as they are, the proposal
    /// grid (with its distortion loss and render samples) still turned on
    /// for open scenes.
    pub const KEEP_SIZES: Fit = Fit { features: false, levels: false, samples: false, ..Fit::ALL };

    /// Every choice but those whose fields the configuration file `over`
    /// (parsed by [`json::parse`]) names: `features.max_res` or
    /// `features.log2_table`; `features.levels`; `sampling.n_coarse`; `sampling.proposal_res`;
    /// `loss.distortion`; `sampling.n_main_render` or `sampling.n_main` (a
    /// chosen training count renders at itself).
    pub fn unless_named(over: &serde_json::Value) -> Fit {
        let names = |section, field| json::names(over, section, field);
        Fit {
            features: !names("features", "max_res") && !names("features", "log2_table"),
            levels: !names("features", "levels"),
            samples: !names("sampling", "n_coarse"),
            proposal: !names("sampling", "proposal_res"),
            distortion: !names("loss", "distortion"),
            render: !names("sampling", "n_main_render") && !names("sampling", "n_main"),
        }
    }
}

/// A configuration fitted to a dataset, and one line for each choice that
/// changed it (what was chosen and the field that chooses otherwise).
#[derive(Clone, Debug)]
pub struct Fitted {
    /// The configuration to train with.
    pub cfg: TrainConfig,
    /// What was chosen for the data, one sentence each.
    pub notes: Vec<String>,
}

/// `cfg` with the choices `fit` turns on made for `data`. A configuration
/// that does not pass [`TrainConfig::validate`] is refused (naming the
/// field), and so is one the proposal grid cannot serve (`sampling.n_main`
/// 0 or above 255, say: [`ConfigError::ProposalGrid`]) rather than trained
/// without the grid.
pub fn fit_to_data(cfg: &TrainConfig, fit: Fit, data: &Dataset) -> Result<Fitted> {
    cfg.validate()?;
    let base = cfg;
    let mut cfg = cfg.clone();
    let open = data.scene.unbounded.is_some() || data.scene.ndc.is_some();
    let kind = if data.scene.ndc.is_some() { "forward-facing" } else { "unbounded" };
    // one network over an occupancy grid: the presets whose stratified samples the proposal replaces
    if fit.proposal
        && open
        && cfg.sampling.proposal_res.is_none()
        && cfg.sampling.n_fine.is_none()
        && cfg.grid.res.is_some()
    {
        // only a configuration the grid can serve (sampling.n_coarse 3..=256, sampling.n_main 1..=255) gets it
        let mut with = cfg.clone().with(|c| c.sampling.proposal_res = Some(TrainConfig::PROPOSAL_RES));
        if fit.samples {
            // the grid composited at fewer stratified samples than the occupancy grid's
            with.sampling.n_coarse = TrainConfig::PROPOSAL_COARSE;
        }
        if fit.distortion {
            with.loss.distortion = TrainConfig::PROPOSAL_DISTORTION;
        }
        // forward-facing scenes render at the samples they train with (flower at 1008×756: +0.27 dB at
        // 32 against 16, docs/RESULTS.md "The paper's protocol"); unbounded ones at fewer, for speed
        if fit.render && data.scene.ndc.is_none() {
            with.sampling.n_main_render = Some(TrainConfig::PROPOSAL_RENDER_MAIN);
        }
        with.validate().map_err(|e| ConfigError::ProposalGrid { kind, source: Box::new(e) })?;
        cfg = with;
    }
    if let Some(cells) = data.resolvable_cells() {
        // a grid sized to the photos keeps its levels close together: forward-facing ones always
        // (flower), others where the configuration's levels would be 2× apart or more (lego at 800×800)
        if fit.features && cfg.fit_features_to(cells) && fit.levels {
            let f = &cfg.features;
            let wide = f.levels.is_some_and(|l| f.max_res as u64 >= (f.min_res as u64) << (l.get() - 1));
            if data.scene.ndc.is_some() || wide {
                cfg.features.levels = Some(TrainConfig::SIZED_LEVELS);
            }
        }
        if fit.samples {
            cfg.fit_samples_to(cells);
        }
    }
    let notes = notes(base, &cfg, data, kind);
    Ok(Fitted { cfg, notes })
}

/// One sentence for each choice that made `cfg` differ from `base`.
fn notes(base: &TrainConfig, cfg: &TrainConfig, data: &Dataset, kind: &str) -> Vec<String> {
    let mut notes = Vec::new();
    if cfg.features.max_res != base.features.max_res {
        notes.push(format!(
            "feature grid sized to the photos: finest level {} cells per axis (was {}), 2^{} table entries per level \
             (was 2^{}){}; set features.max_res or features.log2_table with --config to choose",
            cfg.features.max_res,
            base.features.max_res,
            cfg.features.log2_table,
            base.features.log2_table,
            match cfg.features.levels != base.features.levels {
                true => format!(
                    ", {} levels (was {}; set features.levels with --config to choose)",
                    cfg.features.levels.map_or(0, |l| l.get()),
                    base.features.levels.map_or(0, |l| l.get())
                ),
                false => String::new(),
            }
        ));
    }
    if cfg.sampling.proposal_res != base.sampling.proposal_res {
        notes.push(format!(
            "{kind} scene: the network's {} samples per ray (the model renders at {} unless told otherwise; set \
             sampling.n_main_render with --config) placed by a {}³ proposal grid composited at {} stratified \
             samples{}; set sampling.proposal_res 0 with --config for the occupancy grid's {} stratified samples",
            cfg.sampling.n_main,
            cfg.samples().fine,
            cfg.sampling.proposal_res.map_or(0, |r| r.get()),
            cfg.sampling.n_coarse,
            match cfg.loss.distortion != base.loss.distortion {
                true => format!(", the distortion loss at {} (set loss.distortion with --config)", cfg.loss.distortion),
                false => String::new(),
            },
            base.sampling.n_coarse
        ));
    }
    if cfg.sampling.n_coarse != base.sampling.n_coarse && cfg.sampling.proposal_res == base.sampling.proposal_res {
        notes.push(format!(
            "samples per ray set for the photos: {} (was {}); set sampling.n_coarse with --config to choose",
            cfg.sampling.n_coarse, base.sampling.n_coarse
        ));
    }
    if cfg.per_photo.pose_refine && data.scene.ndc.is_some() {
        notes.push(
            "forward-facing scene: per_photo.pose_refine leaves the photos' poses as loaded (rays in NDC)".into(),
        );
    }
    notes
}
