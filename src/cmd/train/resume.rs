//! `--resume`: the checkpoint's run against the command line (data, downscale,
//! preset and configuration), refused by field where they differ.

use super::*;
use crate::cmd::shell_quote;

/// `--resume` continues the checkpoint's run: a `--downscale`, `--seed` or
/// loading flag that says otherwise is refused, naming what differs.
/// Returns the run's data folder when `--data` names another one with the
/// same flags (moved, or another capture: [`check_resumed_data`] tells).
pub(super) fn check_resume(a: &Args, tr: &Trainer) -> CmdResult<Option<PathBuf>> {
    let data = data_source(a);
    let (path, flags) = split_source(&data);
    let (run_path, run_flags) = split_source(&tr.data);
    if flags != run_flags {
        return Err(CmdError::Flag {
            flag: "the loading flags",
            reason: format!(
                "({}) differ from the run's ({}): resume with the run's, or start over with --force",
                user_flags(flags),
                user_flags(run_flags)
            ),
        });
    }
    if let Some(d) = a.capture.downscale.filter(|&d| d != tr.downscale) {
        return Err(CmdError::Flag {
            flag: "--downscale",
            reason: format!("{d} differs from the checkpoint's {}: resume without it", tr.downscale),
        });
    }
    // a run resumes with its own seed (its random streams go on where they stopped)
    if a.seed != 0 && a.seed != tr.seed {
        return Err(CmdError::Flag {
            flag: "--seed",
            reason: format!("{} differs from the checkpoint's {}: resume without it", a.seed, tr.seed),
        });
    }
    Ok((path != run_path).then(|| PathBuf::from(run_path)))
}

/// The capture loaded for `--resume` against the run's: the scene's frame
/// (fitted from every camera, so it moves when a photo is added, removed
/// or re-posed) and, with per-photo colour corrections or pose
/// refinement, the number of photos must be the run's. A capture in
/// another folder (`moved_from` the run's) must also match what the run's
/// model records of its capture (photo count, held-out names); one that
/// does is taken, with a note, and recorded as the run's from here on (a
/// Blender scene, which records none, is refused).
pub(super) fn check_resumed_data(a: &Args, tr: &mut Trainer, data: &Dataset, moved_from: Option<PathBuf>) -> CmdResult {
    let run_data = match &moved_from {
        Some(p) => p.display().to_string(),
        None => split_source(&tr.data).0.to_string(),
    };
    let way_on = match &moved_from {
        Some(p) => format!("resume with --data {}, or start over with --force", shell_quote(p)),
        None => "resume with the photos it trained on, or start over with --force".into(),
    };
    let photos = data.views.len();
    let refused = |reason: String| Err(CmdError::Flag { flag: "--data", reason });
    let learned = [
        ("a colour correction", tr.appearance.as_ref().map(|p| p.photos())),
        ("a pose correction", tr.poses.as_ref().map(|p| p.photos())),
    ];
    for (what, n) in learned {
        if let Some(n) = n.filter(|&n| n != photos) {
            return refused(format!(
                "{}: {photos} training photos, where the run learned {what} for each of its {n} (in {run_data}): \
                 {way_on}",
                a.data.display()
            ));
        }
    }
    if tr.scene != data.scene {
        return refused(format!(
            "{}: its cameras give another scene frame than the run's capture ({run_data}): photos were added, \
             removed or re-posed since the run started; {way_on}",
            a.data.display()
        ));
    }
    if moved_from.is_some() {
        // the same capture: its record in the run's model (its photo count and held-out names) matches
        let model = a.out.join("model.nerf");
        let recorded = crate::cmd::read_model(&model)
            .ok()
            .and_then(|b| crate::cmd::decode(&model, &b).ok().and_then(|m| m.capture));
        let same = |r: &nerf_infer::format::Capture, d: &nerf_infer::format::Capture| {
            (r.views, r.held_out_crc, r.holdout) == (d.views, d.held_out_crc, d.holdout)
        };
        if !matches!((&recorded, &data.capture), (Some(r), Some(d)) if same(r, d)) {
            return refused(format!(
                "{}: the run trained on {run_data}, and {}: {way_on}",
                a.data.display(),
                match (&recorded, &data.capture) {
                    (Some(_), Some(_)) => "this capture's photos are not those (their number or held-out names differ)",
                    _ => "nothing recorded tells whether this is the same capture",
                }
            ));
        }
        eprintln!(
            "note: the run trained on {run_data}; {} holds the same capture ({photos} training photos, the same scene \
             frame): resuming with it",
            a.data.display()
        );
        tr.data = data_source(a);
    }
    Ok(())
}

/// A data source ([`data_source`]) split into its folder and its flags.
fn split_source(s: &str) -> (&str, &str) {
    s.rsplit_once(" --llffhold ").unwrap_or((s, ""))
}

/// The flags of a data source ([`CaptureArgs::describe`], after its
/// `--llffhold `) as a command line gives them.
fn user_flags(flags: &str) -> String {
    let holdout = flags.split_whitespace().next().unwrap_or("?");
    let field = |name: &str| {
        flags.split_once(&format!("{name}: ")).map(|(_, rest)| rest.split([',', ' ']).next().unwrap_or("").to_string())
    };
    let mut out = format!("--llffhold {holdout}");
    if let Some(scene) = field("scene") {
        out.push_str(&format!(" --scene {}", scene.to_ascii_lowercase()));
    }
    if field("ignore_distortion").as_deref() == Some("true") {
        out.push_str(" --ignore-distortion");
    }
    if field("undistort").as_deref() == Some("true") {
        out.push_str(" --undistort");
    }
    if let Some(n) = field("sparse_model") {
        out.push_str(&format!(" --sparse-model {n}"));
    }
    out
}

/// `--resume` with `--preset` or `--config`: refused, naming the fields,
/// unless they give the checkpoint's configuration (its feature grid sized
/// to `data` as a new run's would be).
pub(super) fn check_resume_config(a: &Args, tr: &Trainer, data: &Dataset) -> CmdResult {
    if a.preset.is_some() || a.config.is_some() {
        let run = load_config(a)?;
        let cfg = nerf_train::run::fit_to_data(&run.cfg, run.fit, data)?.cfg;
        if cfg != tr.cfg {
            let differ = cfg.differing_fields(&tr.cfg);
            return Err(CmdError::Flag {
                flag: "--preset/--config",
                reason: format!(
                    "differ from the checkpoint's configuration in {}: resume without them, or start over with \
                     --force",
                    differ.join(", ")
                ),
            });
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_data_source_reads_back_as_its_folder_and_flags() {
        let mut c = CaptureArgs {
            llffhold: Some(4),
            scene: Some(nerf_train::dataset::SceneKind::Forward),
            ..CaptureArgs::default()
        };
        c.ignore_distortion = true;
        c.sparse_model = Some(2);
        let source = format!("/data/my photos {}", c.describe());
        let (path, flags) = split_source(&source);
        assert_eq!(path, "/data/my photos");
        assert_eq!(user_flags(flags), "--llffhold 4 --scene forward --ignore-distortion --sparse-model 2");
        let plain = format!("/d {}", CaptureArgs::default().describe());
        assert_eq!(user_flags(split_source(&plain).1), "--llffhold 8 --scene auto");
    }
}
