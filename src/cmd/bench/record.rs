//! `OUT/bench.json`: the suite and the flags a bench runs with, written by
//! its first task and checked by every later one, so that tasks started
//! apart (a job array) score the same scenes the same way and a rerun with
//! other flags never mixes its rows with an earlier run's.

use super::suite::{self, Scene};
use super::Args;
use crate::cmd::{CmdError, CmdResult};
use std::path::{Path, PathBuf};

/// The record's file name in the output folder.
pub const RECORD: &str = "bench.json";

/// What a bench runs: the scenes, in task order, and the flags.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Settings {
    /// The suite folder, absolute.
    pub suite: PathBuf,
    /// Its scenes in task order.
    pub scenes: Vec<Scene>,
    /// Training minutes per scene.
    pub minutes: Option<f64>,
    /// Training steps per scene.
    pub iters: Option<u64>,
    /// Seed of every scene's training.
    pub seed: u64,
    /// `--preset`, as named on the command line.
    pub preset: Option<String>,
    /// `--config`: the file as given and its contents.
    pub config: Option<(PathBuf, String)>,
}

impl Settings {
    /// The settings of a run with `a`'s flags (its scenes discovered now).
    pub fn from_args(a: &Args) -> CmdResult<Self> {
        let config = match &a.config {
            Some(p) => {
                let text =
                    nerf_train::util::userfile::read_user_text(p, nerf_train::util::userfile::MAX_JSON, "--config")?;
                let abs = std::path::absolute(p).unwrap_or_else(|_| p.clone());
                Some((abs, text))
            }
            None => None,
        };
        // the suite as one path, however it is reached (a link, `..`): tasks started elsewhere compare equal
        let suite_dir = a.suite.canonicalize().unwrap_or_else(|_| a.suite.clone());
        Ok(Self {
            scenes: suite::discover(&suite_dir, a.downscale)?,
            suite: suite_dir,
            minutes: a.minutes,
            iters: a.iters,
            seed: a.seed,
            preset: a.preset.and_then(|p| clap::ValueEnum::to_possible_value(&p)).map(|v| v.get_name().to_owned()),
            config,
        })
    }

    /// Reads the record of the bench in `out` (for `--gather`).
    pub fn read(out: &Path) -> CmdResult<Self> {
        let path = out.join(RECORD);
        if !path.is_file() {
            return Err(CmdError::File {
                path: out.to_path_buf(),
                reason: format!(
                    "no bench has run here (no {RECORD}): run `nerf bench SUITE --out {}` or its --task I first",
                    crate::cmd::shell_quote(out)
                ),
            });
        }
        let text =
            nerf_train::util::userfile::read_user_text(&path, nerf_train::util::userfile::MAX_JSON, "bench record")?;
        let not_a_record =
            |why: String| CmdError::File { path: path.clone(), reason: format!("not a bench record: {why}") };
        let s: Self = serde_json::from_str(&text).map_err(|e| not_a_record(e.to_string()))?;
        if s.scenes.is_empty() {
            return Err(not_a_record("it names no scene".into()));
        }
        Ok(s)
    }

    /// Makes `out` this bench's folder: creates it and writes the record,
    /// or checks the record already there. Refuses a folder that holds
    /// files and no record (not a bench's), and a record of other scenes
    /// or flags, naming what differs.
    pub fn claim(&self, out: &Path) -> CmdResult {
        super::super::create_dir(out)?;
        let path = out.join(RECORD);
        if !path.exists() {
            // a folder of someone else's: refused; what tasks starting at the same time write is not someone else's
            let foreign = std::fs::read_dir(out)
                .map_err(CmdError::io(out, "cannot list"))?
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .find(|n| n != RECORD && n != "scenes" && !n.starts_with(".tmp"));
            if let Some(f) = foreign {
                return Err(CmdError::Flag {
                    flag: "--out",
                    reason: format!(
                        "{}: holds {f} and no {RECORD}: not a bench's folder; choose an empty or new one",
                        out.display()
                    ),
                });
            }
            let text = serde_json::to_string_pretty(self)?;
            // of tasks starting together exactly one writes the record, whole; the others compare with it
            nerf_train::util::atomic::write_new(&path, text.as_bytes()).map_err(CmdError::io(&path, "cannot write"))?;
        }
        let there = Self::read(out)?;
        match self.difference(&there) {
            None => Ok(()),
            Some(d) => Err(CmdError::Flag {
                flag: "--out",
                reason: format!(
                    "{}: holds a bench run {d}; rerun with its flags to resume it, or choose another --out",
                    out.display()
                ),
            }),
        }
    }

    /// How `there` (a record on disk) differs from these settings, in words.
    fn difference(&self, there: &Settings) -> Option<String> {
        if self.suite != there.suite {
            return Some(format!("of the suite {}", there.suite.display()));
        }
        if self.scenes != there.scenes {
            let names = |s: &Settings| s.scenes.iter().map(|s| s.name.clone()).collect::<Vec<_>>();
            let (now, then) = (names(self), names(there));
            let added: Vec<&String> = now.iter().filter(|n| !then.contains(n)).collect();
            let gone: Vec<&String> = then.iter().filter(|n| !now.contains(n)).collect();
            if !added.is_empty() || !gone.is_empty() {
                return Some(format!("of other scenes (the suite has gained {added:?} and lost {gone:?} since)"));
            }
            let (a, b) = self.scenes.iter().zip(&there.scenes).find(|(a, b)| a != b)?;
            return Some(if a.downscale != b.downscale {
                format!("whose scene {} was at 1/{} size (--downscale)", b.name, b.downscale)
            } else if a.kind != b.kind {
                format!("whose scene {} was a {} scene", b.name, b.kind.name())
            } else {
                format!("whose scene {} was in {}", b.name, b.dir.display())
            });
        }
        let budget = |s: &Settings| match (s.minutes, s.iters) {
            (Some(m), _) => format!("--minutes {m}"),
            (None, Some(n)) => format!("--iters {n}"),
            _ => "no budget".into(),
        };
        if (self.minutes, self.iters) != (there.minutes, there.iters) {
            return Some(format!("with {}", budget(there)));
        }
        if self.seed != there.seed {
            return Some(format!("with --seed {}", there.seed));
        }
        if self.preset != there.preset {
            return Some(format!("with --preset {}", there.preset.as_deref().unwrap_or("(default)")));
        }
        if self.config != there.config {
            return Some(match &there.config {
                Some((p, _)) => format!("with --config {} as it was then", p.display()),
                None => "without --config".into(),
            });
        }
        None
    }
}
