//! A suite: the scenes of a folder in a stable order, each with the
//! protocol it is scored at, and the published figure beside it.
//!
//! A suite folder holds scene folders (`nerf_synthetic/`, `nerf_llff_data/`
//! or a folder of the user's captures), or is one scene itself. Scenes are
//! ordered by folder name (byte order): that order numbers the tasks of
//! `--task`.

use crate::cmd::{CmdError, CmdResult};
use nerf_train::dataset::{detect, Format};
use std::path::{Path, PathBuf};

/// How a scene is scored: the paper's protocol for its kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    /// Blender split files (`nerf_synthetic`): full resolution, white
    /// background, the test split (the validation split where a scene
    /// ships no test split).
    Synthetic,
    /// LLFF (`nerf_llff_data`): 1/4 size (`images_4/`, 1008×756 for the
    /// paper's scenes), every 8th photo held out and scored.
    ForwardFacing,
    /// A capture of the user's (COLMAP, instant-ngp, nerfstudio): the
    /// suite's `--downscale`, every 8th photo held out and scored (its test
    /// split file where it has one).
    Capture,
}

impl Kind {
    /// The name the table prints.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Synthetic => "synthetic",
            Kind::ForwardFacing => "forward-facing",
            Kind::Capture => "capture",
        }
    }
}

/// One scene of a suite and the protocol it is run at.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scene {
    /// Folder name, the scene's name in the table.
    pub name: String,
    /// The scene's folder.
    pub dir: PathBuf,
    /// Its kind, which sets the protocol.
    pub kind: Kind,
    /// Downscale factor the photos are trained and scored at.
    pub downscale: u32,
}

impl Scene {
    /// The split whose views are scored: `test`, or `val` for a Blender
    /// scene that ships no `transforms_test.json` (the table says which).
    pub fn scored_split(&self) -> nerf_train::dataset::Split {
        use nerf_train::dataset::Split;
        let split_files = self.dir.join("transforms_train.json").is_file();
        if split_files
            && !self.dir.join("transforms_test.json").is_file()
            && self.dir.join("transforms_val.json").is_file()
        {
            Split::Val
        } else {
            Split::Test
        }
    }
}

/// The published PSNR (dB) and SSIM of the 2020 NeRF on a scene at this
/// protocol: the per-scene tables of Mildenhall et al., ECCV 2020
/// (arXiv:2003.08934, supplementary Tables 4 and 5; their means are the
/// 31.01 / 0.947 and 26.50 / 0.811 of the paper's Table 1).
pub fn published(kind: Kind, name: &str) -> Option<(f64, f64)> {
    const SYNTHETIC: [(&str, f64, f64); 8] = [
        ("chair", 33.00, 0.967),
        ("drums", 25.01, 0.925),
        ("ficus", 30.13, 0.964),
        ("hotdog", 36.18, 0.974),
        ("lego", 32.54, 0.961),
        ("materials", 29.62, 0.949),
        ("mic", 32.91, 0.980),
        ("ship", 28.65, 0.856),
    ];
    const FORWARD: [(&str, f64, f64); 8] = [
        ("room", 32.70, 0.948),
        ("fern", 25.17, 0.792),
        ("leaves", 20.92, 0.690),
        ("fortress", 31.16, 0.881),
        ("orchids", 20.36, 0.641),
        ("flower", 27.40, 0.827),
        ("trex", 26.80, 0.880),
        ("horns", 27.45, 0.828),
    ];
    let table: &[(&str, f64, f64)] = match kind {
        Kind::Synthetic => &SYNTHETIC,
        Kind::ForwardFacing => &FORWARD,
        Kind::Capture => return None,
    };
    let name = name.to_ascii_lowercase();
    table.iter().find(|(n, _, _)| *n == name).map(|&(_, p, s)| (p, s))
}

/// The scene in `dir`, if it is one (named `name`), at the protocol of its
/// kind; captures at `capture_downscale`.
fn scene_at(dir: &Path, name: String, capture_downscale: u32) -> Option<Scene> {
    let kind = match detect(dir).ok()? {
        Format::Blender => Kind::Synthetic,
        Format::Llff => Kind::ForwardFacing,
        Format::Ngp | Format::Colmap | Format::Auto => Kind::Capture,
    };
    let downscale = match kind {
        Kind::Synthetic => 1,
        Kind::ForwardFacing => 4,
        Kind::Capture => capture_downscale,
    };
    Some(Scene { name, dir: dir.to_path_buf(), kind, downscale })
}

/// The scenes of the suite folder `suite`, ordered by name: its
/// subfolders that hold a scene, or the folder itself if it is one.
/// Captures are run at `capture_downscale`. Fails naming the folder when
/// it holds no scene.
pub fn discover(suite: &Path, capture_downscale: u32) -> CmdResult<Vec<Scene>> {
    let abs = std::path::absolute(suite).unwrap_or_else(|_| suite.to_path_buf());
    if !abs.is_dir() {
        return Err(CmdError::File {
            path: suite.to_path_buf(),
            reason: "no such folder (SUITE is a folder of scenes, or one scene)".into(),
        });
    }
    let own_name = abs.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    if let Some(s) = scene_at(&abs, own_name, capture_downscale) {
        return Ok(vec![s]);
    }
    let mut dirs: Vec<(String, PathBuf)> = std::fs::read_dir(&abs)
        .map_err(CmdError::io(suite, "cannot list"))?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
        .filter(|(n, _)| !n.starts_with('.'))
        .collect();
    dirs.sort();
    let scenes: Vec<Scene> = dirs.into_iter().filter_map(|(n, p)| scene_at(&p, n, capture_downscale)).collect();
    if scenes.is_empty() {
        return Err(CmdError::File {
            path: suite.to_path_buf(),
            reason: "no scene found: neither the folder nor a subfolder holds transforms_train.json (Blender), \
                     poses_bounds.npy (LLFF), transforms.json (instant-ngp, nerfstudio) or a COLMAP sparse model"
                .into(),
        });
    }
    Ok(scenes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_means_are_the_papers_table_1() {
        let mean = |kind, names: &[&str]| {
            let v: Vec<(f64, f64)> = names.iter().map(|n| published(kind, n).unwrap()).collect();
            let n = v.len() as f64;
            (v.iter().map(|p| p.0).sum::<f64>() / n, v.iter().map(|p| p.1).sum::<f64>() / n)
        };
        // Table 1 rounds the means to its last digit: within half of it (31.005 is printed 31.01)
        let near = |x: f64, printed: f64, half: f64| (x - printed).abs() <= half + 1e-9;
        let syn = ["chair", "drums", "ficus", "hotdog", "lego", "materials", "mic", "ship"];
        let (p, s) = mean(Kind::Synthetic, &syn);
        assert!(near(p, 31.01, 0.005) && near(s, 0.947, 0.0005), "{p} {s}");
        let ff = ["room", "fern", "leaves", "fortress", "orchids", "flower", "trex", "horns"];
        let (p, s) = mean(Kind::ForwardFacing, &ff);
        assert!(near(p, 26.50, 0.005) && near(s, 0.811, 0.0005), "{p} {s}");
        assert_eq!(published(Kind::Synthetic, "Lego"), Some((32.54, 0.961)));
        assert_eq!(published(Kind::ForwardFacing, "lego"), None);
        assert_eq!(published(Kind::Capture, "flower"), None);
    }
}
