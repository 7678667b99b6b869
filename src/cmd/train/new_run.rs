//! A new run's configuration: the preset, the `--config` file on top, and
//! the choices `nerf train` makes for the data (the proposal grid of open
//! scenes, the feature grid and samples sized to the photos).

use super::Args;
use nerf_train::config::TrainConfig;
use nerf_train::dataset::Dataset;

/// A new run's configuration, from `--preset` and `--config`.
#[derive(Debug)]
pub(super) struct NewRun {
    /// The preset with the file's fields on top.
    pub(super) cfg: TrainConfig,
    /// Size the feature grid to the photos ([`TrainConfig::fit_features_to`]):
    /// unless `--config` names `features.max_res` or `features.log2_table`.
    pub(super) fit_features: bool,
    /// Set the samples per ray for the photos ([`TrainConfig::fit_samples_to`]),
    /// or to [`TrainConfig::PROPOSAL_COARSE`] where a proposal grid is
    /// turned on: unless `--config` names `sampling.n_coarse`.
    pub(super) fit_samples: bool,
    /// Place the network's samples with a proposal grid in unbounded and
    /// forward-facing scenes ([`SamplingConfig::proposal_res`](nerf_train::config::SamplingConfig::proposal_res)): unless
    /// `--config` names `sampling.proposal_res`.
    pub(super) fit_proposal: bool,
    /// Turn the distortion loss on ([`TrainConfig::PROPOSAL_DISTORTION`])
    /// where the proposal grid is turned on (unbounded and forward-facing
    /// scenes): unless `--config` names `loss.distortion`.
    pub(super) fit_distortion: bool,
    /// Render the model at [`TrainConfig::PROPOSAL_RENDER_MAIN`] network
    /// samples by default where the proposal grid is turned on in an
    /// unbounded scene (a forward-facing one renders at the samples it
    /// trains with): unless
    /// `--config` names `sampling.n_main_render` or `sampling.n_main` (a
    /// chosen training count renders at itself).
    pub(super) fit_render: bool,
}

impl NewRun {
    /// The configuration to train on `data`: with `fit_features`, its feature
    /// grid sized to what the photos resolve; with `fit_samples`, its
    /// samples per ray set for them.
    /// A configuration the proposal grid cannot serve (`sampling.n_main`
    /// 0 or above 255, say) is refused, naming the field, rather than
    /// trained without the grid.
    pub(super) fn for_data(&self, data: &Dataset) -> Result<TrainConfig, String> {
        let mut cfg = self.cfg.clone();
        let open = data.scene.unbounded.is_some() || data.scene.ndc.is_some();
        // one network over an occupancy grid: the presets whose stratified samples the proposal replaces
        if self.fit_proposal && open && cfg.sampling.proposal_res == 0 && cfg.sampling.n_fine == 0 && cfg.grid.res > 0 {
            // only a configuration the grid can serve (sampling.n_coarse 3..=256, sampling.n_main 1..=255) gets it
            let mut with = cfg.clone().with(|c| c.sampling.proposal_res = TrainConfig::PROPOSAL_RES);
            if self.fit_samples {
                // the grid composited at fewer stratified samples than the occupancy grid's
                with.sampling.n_coarse = TrainConfig::PROPOSAL_COARSE;
            }
            if self.fit_distortion {
                with.loss.distortion = TrainConfig::PROPOSAL_DISTORTION;
            }
            // forward-facing scenes render at the samples they train with (flower at 1008×756: +0.27 dB at
            // 32 against 16, docs/RESULTS.md "The paper's protocol"); unbounded ones at fewer, for speed
            if self.fit_render && data.scene.ndc.is_none() {
                with.sampling.n_main_render = TrainConfig::PROPOSAL_RENDER_MAIN;
            }
            with.validate().map_err(|e| {
                format!(
                    "invalid configuration: {e} (the proposal grid this {} scene gets; set sampling.proposal_res 0 \
                     with --config to train it with the occupancy grid instead)",
                    if data.scene.ndc.is_some() { "forward-facing" } else { "unbounded" }
                )
            })?;
            cfg = with;
        }
        if let Some(cells) = data.resolvable_cells() {
            if self.fit_features {
                cfg.fit_features_to(cells);
            }
            if self.fit_samples {
                cfg.fit_samples_to(cells);
            }
        }
        Ok(cfg)
    }
}

pub(super) fn load_config(a: &Args) -> Result<NewRun, String> {
    let base = a.preset.unwrap_or_default().config();
    let (mut fit_features, mut fit_samples, mut fit_proposal, mut fit_distortion, mut fit_render) =
        (true, true, true, true, true);
    let cfg = match &a.config {
        None => base,
        Some(path) => {
            let bad = |e: &dyn std::fmt::Display| format!("{}: invalid configuration: {e}", path.display());
            let text = nerf_train::userfile::read_user_text(path, nerf_train::userfile::MAX_JSON, "--config")?;
            let over = nerf_train::config::json::parse(&text).map_err(|e| bad(&e))?;
            let names = |section, field| nerf_train::config::json::names(&over, section, field);
            fit_features = !names("features", "max_res") && !names("features", "log2_table");
            fit_samples = !names("sampling", "n_coarse");
            fit_proposal = !names("sampling", "proposal_res");
            fit_distortion = !names("loss", "distortion");
            fit_render = !names("sampling", "n_main_render") && !names("sampling", "n_main");
            // the preset's fields, then the file's on top of them
            base.overlay(&over).map_err(|e| bad(&e))?
        }
    };
    cfg.validate().map_err(|e| format!("invalid configuration: {e}"))?;
    Ok(NewRun { cfg, fit_features, fit_samples, fit_proposal, fit_distortion, fit_render })
}
