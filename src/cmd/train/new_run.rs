//! A new run's configuration: the preset, the `--config` file on top, and
//! which of the choices for the data ([`nerf_train::run::fit_to_data`]) the
//! file leaves to the run.

use super::Args;
use crate::cmd::{CmdError, CmdResult};
use nerf_train::config::TrainConfig;
use nerf_train::run::Fit;

/// A new run's configuration, from `--preset` and `--config`.
#[derive(Debug)]
pub(super) struct NewRun {
    /// The preset with the file's fields on top.
    pub(super) cfg: TrainConfig,
    /// The choices made for the data: those whose fields the file does not name.
    pub(super) fit: Fit,
}

pub(super) fn load_config(a: &Args) -> CmdResult<NewRun> {
    let base = a.preset.unwrap_or_default().config();
    let (cfg, fit) = match &a.config {
        None => (base, Fit::ALL),
        Some(path) => {
            let bad = |e: &dyn std::fmt::Display| CmdError::File {
                path: path.clone(),
                reason: format!("invalid configuration: {e}"),
            };
            let text =
                nerf_train::util::userfile::read_user_text(path, nerf_train::util::userfile::MAX_JSON, "--config")?;
            let over = nerf_train::config::json::parse(&text).map_err(|e| bad(&e))?;
            // the preset's fields, then the file's on top of them
            (base.overlay(&over).map_err(|e| bad(&e))?, Fit::unless_named(&over))
        }
    };
    cfg.validate().map_err(CmdError::within("invalid configuration"))?;
    Ok(NewRun { cfg, fit })
}
