//! Pruning: hidden units whose ReLU never fires on the calibration rays are
//! dropped, with the rows that read them.

use super::*;

/// Which neurons never active on the calibration rays the exported model
/// drops (`nerf train --prune`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Prune {
    /// Keep every neuron.
    Off,
    /// Drop dead neurons in groups of 32 (layer widths stay on the kernels' register tile: no slowdown).
    ///
    /// A layer at least [`OUTPUT_TILE`] wide keeps a multiple of it,
    /// padded with dead neurons, so the kernels run only whole register
    /// tiles; narrower layers are pruned exactly.
    Tiles,
    /// Drop every dead neuron (fewest bytes; widths off the 32 grain render slower).
    ///
    /// Such widths take the kernels' slower remainder loop
    /// (docs/EXPERIMENTS.md, "Pruning on this model", counts what that
    /// costs with AVX2).
    Exact,
}

/// The outputs of a layer `old` wide to keep, given which were active.
pub(super) fn kept_outputs(act: &[bool], old: usize, prune: Prune) -> Vec<usize> {
    let alive = |c: &usize| act.get(*c).copied().unwrap_or(true);
    let mut keep: Vec<usize> = (0..old).filter(alive).collect();
    let want = match prune {
        Prune::Off => old,
        Prune::Tiles if old >= OUTPUT_TILE => keep.len().div_ceil(OUTPUT_TILE).max(1) * OUTPUT_TILE,
        Prune::Tiles | Prune::Exact => keep.len().max(1),
    };
    // pad with the first dead outputs, keeping the original order
    let mut dead = (0..old).filter(|c| !alive(c));
    while keep.len() < want.min(old) {
        keep.push(dead.next().expect("fewer outputs kept than the layer has"));
    }
    keep.sort_unstable();
    keep
}

/// Removes from an f32 network the ReLU outputs (trunk and view layers)
/// that were never positive on the calibration samples (`active[l][c]`
/// false), as `prune` says: their column in layer `l` and their input row
/// in the layers that read them. On the calibration samples the pruned
/// network computes exactly what the full one does (a removed output was
/// 0). A layer keeps at least one output. Layers without an `active` entry
/// stay whole.
pub fn prune_network(
    t: &Topology,
    e: &Encoding,
    net: &OwnedNetwork,
    active: &[Vec<bool>],
    prune: Prune,
) -> OwnedNetwork {
    let mut layers = net.layers.clone();
    let d = t.depth as usize;
    for i in 0..layers.len() {
        let Some(act) = active.get(i).filter(|_| format::prunable(t, i)) else { continue };
        let old = layers[i].out_dim as usize;
        let keep = kept_outputs(act, old, prune);
        if keep.len() == old {
            continue;
        }
        keep_columns(&mut layers[i], &keep);
        // readers of layer i's outputs, and the row where those inputs start
        let readers: Vec<(usize, usize)> = if i + 1 < d {
            vec![(i + 1, if t.is_skip(i + 1) { e.pos_dim() } else { 0 })]
        } else if i + 1 == d {
            vec![(d, 0), (d + 1, 0)]
        } else {
            vec![(i + 1, 0)]
        };
        for (k, off) in readers {
            keep_rows(&mut layers[k], off, old, &keep);
        }
    }
    OwnedNetwork { layers, ..net.clone() }
}

/// Keeps the output columns `keep` of an f32 layer.
pub(super) fn keep_columns(l: &mut OwnedLayer, keep: &[usize]) {
    let (din, dout) = (l.in_dim as usize, l.out_dim as usize);
    let w = |j: usize, c: usize| read_f32(&l.weights, j * dout + c);
    l.weights = f32_bytes((0..din).flat_map(|j| keep.iter().map(move |&c| w(j, c))).collect::<Vec<_>>());
    l.bias = f32_bytes(keep.iter().map(|&c| read_f32(&l.bias, c)).collect::<Vec<_>>());
    l.out_dim = keep.len() as u16;
}

/// Keeps, of the `n` input rows starting at `off`, the rows `off + keep[k]`
/// (all rows outside that range stay).
pub(super) fn keep_rows(l: &mut OwnedLayer, off: usize, n: usize, keep: &[usize]) {
    let (din, dout) = (l.in_dim as usize, l.out_dim as usize);
    let rows: Vec<usize> = (0..off).chain(keep.iter().map(|&c| off + c)).chain(off + n..din).collect();
    let w = |j: usize, c: usize| read_f32(&l.weights, j * dout + c);
    l.weights = f32_bytes(rows.iter().flat_map(|&j| (0..dout).map(move |c| w(j, c))).collect::<Vec<_>>());
    l.in_dim = rows.len() as u16;
}
