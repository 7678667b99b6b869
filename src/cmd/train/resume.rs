//! `--resume`: the checkpoint's run against the command line (data, downscale,
//! preset and configuration), refused by field where they differ.

use super::*;

/// `--resume` continues the checkpoint's run: a `--data` or `--downscale`
/// that says otherwise is refused, naming what differs.
pub(super) fn check_resume(a: &Args, tr: &Trainer) -> CmdResult {
    let data = data_source(a);
    if tr.data != data {
        return Err(format!(
            "--data and its loading flags ({data}) differ from the checkpoint's ({}): resume with the run's data, \
             or start over with --force",
            tr.data
        ));
    }
    if let Some(d) = a.capture.downscale.filter(|&d| d != tr.downscale) {
        return Err(format!("--downscale {d} differs from the checkpoint's {}: resume without it", tr.downscale));
    }
    // a run resumes with its own seed (its random streams go on where they stopped)
    if a.seed != 0 && a.seed != tr.seed {
        return Err(format!("--seed {} differs from the checkpoint's {}: resume without it", a.seed, tr.seed));
    }
    Ok(())
}

/// `--resume` with `--preset` or `--config`: refused, naming the fields,
/// unless they give the checkpoint's configuration (its feature grid sized
/// to `data` as a new run's would be).
pub(super) fn check_resume_config(a: &Args, tr: &Trainer, data: &Dataset) -> CmdResult {
    if a.preset.is_some() || a.config.is_some() {
        let cfg = load_config(a)?.for_data(data)?;
        if cfg != tr.cfg {
            let differ = cfg.differing_fields(&tr.cfg);
            return Err(format!(
                "--preset/--config differ from the checkpoint's configuration in {}: resume without them, or \
                 start over with --force",
                differ.join(", ")
            ));
        }
    }
    Ok(())
}

/// The dataset a run trains on, as stored in its checkpoint: the absolute
/// path and the flags that change which views and rays are loaded.
pub(super) fn data_source(a: &Args) -> String {
    let path = a.data.canonicalize().unwrap_or_else(|_| a.data.clone());
    format!("{} {}", path.display(), a.capture.describe())
}
