//! Which of a COLMAP folder's reconstructions to load. COLMAP's mapper
//! writes one model per connected set of photos it could register
//! (`sparse/0`, `sparse/1`, …), in no order of size: the complete one may
//! be any of them. The one with the most registered images is taken unless
//! one is named (`--sparse-model N`), and the choice is reported.

use super::colmap_io::{read_images_bin, read_images_txt};
use super::types::DataError;
use std::path::{Path, PathBuf};

/// Whether `d` holds a COLMAP model (`cameras.bin` or `cameras.txt`).
fn holds_model(d: &Path) -> bool {
    d.join("cameras.bin").is_file() || d.join("cameras.txt").is_file()
}

/// The numbered reconstructions `dir/sparse/N` that hold a model, by `N`.
pub fn numbered_models(dir: &Path) -> Vec<(u32, PathBuf)> {
    let Ok(entries) = std::fs::read_dir(dir.join("sparse")) else { return Vec::new() };
    let mut found: Vec<(u32, PathBuf)> = entries
        .filter_map(|e| e.ok())
        .filter_map(|e| Some((e.file_name().to_str()?.parse::<u32>().ok()?, e.path())))
        .filter(|(_, p)| holds_model(p))
        .collect();
    found.sort();
    found
}

/// The model folder of a capture without choosing among several: the
/// first numbered reconstruction, else `dir/sparse`, else `dir` itself,
/// the first that holds a model.
pub fn find_model_dir(dir: &Path) -> Option<PathBuf> {
    let first = numbered_models(dir).into_iter().next().map(|(_, p)| p);
    first.or_else(|| [dir.join("sparse"), dir.to_path_buf()].into_iter().find(|d| holds_model(d)))
}

/// How many images the model in `model_dir` registers.
pub fn registered_images(model_dir: &Path) -> Result<usize, DataError> {
    let bin = model_dir.join("images.bin");
    let images = if bin.is_file() { read_images_bin(&bin)? } else { read_images_txt(&model_dir.join("images.txt"))? };
    Ok(images.len())
}

/// The reconstruction to load from the COLMAP capture `dir`: `named`
/// (`sparse/N`) if given, else the numbered one registering the most
/// images (the lowest `N` among equals), else `sparse/` or `dir`. With a
/// choice among several, also a note saying which and why.
pub fn choose_model(dir: &Path, named: Option<u32>) -> Result<(PathBuf, Option<String>), DataError> {
    let models = numbered_models(dir);
    if let Some(n) = named {
        let list = models.iter().map(|(k, _)| format!("sparse/{k}")).collect::<Vec<_>>().join(", ");
        return match models.into_iter().find(|(k, _)| *k == n) {
            Some((_, p)) => Ok((p, None)),
            None => Err(DataError::new(
                dir.join("sparse").join(n.to_string()),
                format!(
                    "--sparse-model {n}: no such reconstruction (this capture has {})",
                    if list.is_empty() { "no numbered ones".to_string() } else { list }
                ),
            )),
        };
    }
    if models.len() < 2 {
        return find_model_dir(dir).map(|p| (p, None)).ok_or_else(|| {
            DataError::new(dir, "no COLMAP model: expected sparse/0/ or sparse/ with cameras and images")
        });
    }
    let mut counted = Vec::with_capacity(models.len());
    for (k, p) in models {
        let n = registered_images(&p)?;
        counted.push((k, p, n));
    }
    let best = counted.iter().enumerate().max_by_key(|(i, c)| (c.2, std::cmp::Reverse(*i))).map(|(i, _)| i);
    let best = best.expect("two or more models");
    let (_, p, n) = counted[best].clone();
    // by folder, not number: sparse/0 and sparse/00 are two reconstructions
    let folder = |p: &Path| p.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    let others: Vec<String> = counted
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != best)
        .map(|(_, c)| format!("sparse/{}: {}", folder(&c.1), c.2))
        .collect();
    let note = format!(
        "{}: loading sparse/{}, the reconstruction with the most registered images ({n}; {}); \
         --sparse-model N loads another",
        dir.join("sparse").display(),
        folder(&p),
        others.join(", ")
    );
    Ok((p, Some(note)))
}
