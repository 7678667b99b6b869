//! The occupancy grid coarsened and the feature table narrowed to 8- or
//! 4-bit codes (Lloyd-Max codebooks per level, weighted by use).

use super::*;

/// The occupancy grid of `m` coarsened to `res` cells per axis (a divisor
/// of the model's resolution): a coarse cell is occupied if any of the
/// fine cells it covers is, so nothing occupied is ever skipped; only
/// more empty space is sampled. Bits shrink by `(old/res)³`.
pub fn coarsen_grid(m: &mut OwnedModel, res: u16) -> Result<(), Error> {
    let Some((old, bits)) = &m.grid else {
        return Err(ExportError::NoGrid.into());
    };
    let (old, new) = (*old as usize, res as usize);
    if new == 0 || new > old || old % new != 0 {
        return Err(ExportError::GridRes { res, model: old }.into());
    }
    let f = old / new;
    let mut out = vec![0u8; nerf_infer::occupancy::grid_bytes(res)];
    for i in 0..old * old * old {
        if bits[i / 8] >> (i % 8) & 1 == 1 {
            let (x, y, z) = (i % old / f, i / old % old / f, i / (old * old) / f);
            let j = x + new * (y + new * z);
            out[j / 8] |= 1 << (j % 8);
        }
    }
    m.grid = Some((res, out));
    Ok(())
}

/// Whether a model of `scheme` can take a feature table of `bits`-bit
/// codebook indices ([`narrow_table`]'s own check, for a caller that knows
/// the scheme before it has the model): it needs integer weights (int16 or
/// int8; an f32 model keeps an f32 table) and `bits` 8 or 4.
pub fn narrow_table_fits(scheme: nerf_infer::Scheme, bits: u8) -> Result<(), Error> {
    if !matches!(bits, 4 | 8) {
        return Err(ExportError::TableBits { bits }.into());
    }
    if !scheme.is_fixed() {
        return Err(ExportError::TableOfF32 { bits }.into());
    }
    Ok(())
}

/// The feature table of an integer model stored as `bits`-bit (8 or 4)
/// indices into a codebook of `2^bits` i16 values per level (format
/// version 7, [`NarrowTable`](nerf_infer::features::NarrowTable)). Each level's codebook is the Lloyd–Max
/// quantiser of its values, each value weighted by how much a lattice of
/// points in the occupancy grid's occupied cells reads it (the samples a
/// render evaluates): 1-D k-means from the better of two starts (even
/// codes over the values' range, their weighted quantiles), a local least
/// weighted squared error, so the codes go where the values that reach
/// the pixels are. Each value stores its nearest code; the table is padded
/// to whole 4-byte words.
pub fn narrow_table(m: &mut OwnedModel, bits: u8) -> Result<(), Error> {
    narrow_table_fits(m.coarse.scheme, bits)?;
    let Some((shape, table)) = &mut m.features else {
        return Err(ExportError::NoFeatures.into());
    };
    if m.narrow.is_some() {
        return Err(ExportError::AlreadyNarrow.into());
    }
    let weights = value_weights(shape, m.grid.as_ref());
    let w = shape.width as usize;
    let mut index = Vec::with_capacity(shape.values());
    let mut codebook = Vec::with_capacity(shape.levels() << bits);
    for l in 0..shape.levels() {
        let range = shape.offset(l) * w..shape.offset(l + 1) * w;
        let level: Vec<i16> = range.clone().map(|k| read_i16(table, k)).collect();
        let codes = lloyd_max(&level, &weights[range], 1 << bits);
        let nearest = nearest_code(&codes);
        index.extend(level.iter().map(|&t| nearest(t as i64) as u8));
        codebook.extend(codes);
    }
    *table = match bits {
        8 => index,
        _ => index.chunks(2).map(|p| p[0] | p.get(1).copied().unwrap_or(0) << 4).collect(),
    };
    // padded with zeros to whole 4-byte words
    table.resize(table.len().next_multiple_of(4), 0);
    m.narrow = Some((bits, codebook.iter().flat_map(|c| c.to_le_bytes()).collect()));
    Ok(())
}

/// Each table value's weight in the fit of its level's codes: the
/// trilinear weight its entry takes, summed over points on an even lattice
/// within the occupied cells of the occupancy grid `grid` (the cells a
/// render evaluates; the whole bounds without a grid), about 32 points per
/// value and at most 2²¹; plus a floor of 10⁻³ of the mean weight, so that
/// values no point reads still count a little.
pub(super) fn value_weights(shape: &FeatureGrid<'_>, grid: Option<&(u16, Vec<u8>)>) -> Vec<f64> {
    let (res, occupied): (usize, Vec<[usize; 3]>) = match grid {
        Some((r, bits)) => {
            let g = format::Occupancy { res: *r, bits };
            let r = *r as usize;
            (r, (0..r * r * r).filter(|&i| g.cell(i)).map(|i| [i % r, i / r % r, i / (r * r)]).collect())
        }
        None => (1, vec![[0; 3]]),
    };
    let w = shape.width as usize;
    let mut weights = vec![0.0f64; shape.values()];
    let points = (32 * shape.values()).min(1 << 21);
    // points per cell: s³ on a lattice of cell centres' offsets
    let s = ((points as f64 / occupied.len().max(1) as f64).cbrt().round() as usize).max(1);
    let step = 2.0 / (res * s) as f32;
    for c in &occupied {
        for j in 0..s * s * s {
            let sub = [j % s, j / s % s, j / (s * s)];
            let p: [f32; 3] = core::array::from_fn(|a| -1.0 + ((c[a] * s + sub[a]) as f32 + 0.5) * step);
            for l in 0..shape.levels() {
                let corners = shape.corners_f32(l, p);
                let base = shape.offset(l);
                for (e, cw) in corners.entry.iter().zip(corners.weight) {
                    let k = (base + *e as usize) * w;
                    weights[k..k + w].iter_mut().for_each(|v| *v += cw as f64);
                }
            }
        }
    }
    let floor = 1e-3 * weights.iter().sum::<f64>() / weights.len().max(1) as f64;
    weights.iter_mut().for_each(|v| *v += floor.max(f64::MIN_POSITIVE));
    weights
}

/// `k` sorted i16 codes that quantise `values`, each counted with its
/// weight (> 0), with the least weighted squared error Lloyd's iterations
/// reach from two starts: `k` even codes over the values' range, and the
/// values' weighted quantiles (the better of the two is kept). A code left
/// without values moves to split the cluster with the most weighted
/// squared error, so no code is wasted while a cluster holds two distinct
/// values; fewer distinct values than codes leave the surplus codes
/// repeating the largest.
pub(super) fn lloyd_max(values: &[i16], weights: &[f64], k: usize) -> Vec<i16> {
    let mut v: Vec<(i64, f64)> = values.iter().zip(weights).map(|(&x, &w)| (x as i64, w)).collect();
    v.sort_unstable_by_key(|p| p.0);
    let n = v.len();
    if n == 0 {
        return vec![0; k];
    }
    // prefix sums of w, w·x and w·x²: a run's weighted mean and squared error in O(1)
    let (mut sw, mut swx, mut swxx) = (vec![0.0f64; n + 1], vec![0.0f64; n + 1], vec![0.0f64; n + 1]);
    for (i, &(x, w)) in v.iter().enumerate() {
        let x = x as f64;
        (sw[i + 1], swx[i + 1], swxx[i + 1]) = (sw[i] + w, swx[i] + w * x, swxx[i] + w * x * x);
    }
    let mean = |a: usize, b: usize| (swx[b] - swx[a]) / (sw[b] - sw[a]);
    let sse = |&(a, b): &(usize, usize)| (swxx[b] - swxx[a]) - (swx[b] - swx[a]).powi(2) / (sw[b] - sw[a]);
    // the runs of sorted values nearest each code; empty ones dropped
    let runs_of = |c: &[f64]| {
        let mut runs = Vec::with_capacity(k);
        let mut a = 0;
        for i in 0..c.len() {
            let b = if i + 1 < c.len() { v.partition_point(|p| (p.0 as f64) < 0.5 * (c[i] + c[i + 1])) } else { n };
            if b > a {
                runs.push((a, b));
            }
            a = b;
        }
        runs
    };
    let lloyd = |mut c: Vec<f64>| {
        for _ in 0..1000 {
            let mut runs = runs_of(&c);
            // refill: split the run of two or more distinct values with the most error at its mean
            while runs.len() < k {
                let splittable = runs.iter().enumerate().filter(|(_, &(a, b))| v[a].0 != v[b - 1].0);
                let Some((i, &(a, b))) = splittable.max_by(|x, y| sse(x.1).total_cmp(&sse(y.1))) else {
                    break; // every run is one distinct value
                };
                let m = a + v[a..b].partition_point(|p| (p.0 as f64) <= mean(a, b)).clamp(1, b - a - 1);
                runs.splice(i..=i, [(a, m), (m, b)]);
            }
            let next: Vec<f64> = runs.iter().map(|&(a, b)| mean(a, b)).collect();
            if next == c {
                break;
            }
            c = next;
        }
        let mut codes: Vec<i16> = c.iter().map(|x| x.round() as i16).collect();
        codes.dedup();
        codes.resize(k, *codes.last().unwrap_or(&0));
        codes
    };
    let (lo, hi) = (v[0].0 as f64, v[n - 1].0 as f64);
    let even = lloyd((0..k).map(|i| lo + (hi - lo) * (i as f64 + 0.5) / k as f64).collect());
    let quantiles = lloyd({
        let mut q: Vec<f64> = (0..k)
            .map(|i| v[sw.partition_point(|&s| s < sw[n] * (i as f64 + 0.5) / k as f64).clamp(1, n) - 1].0 as f64)
            .collect();
        q.dedup();
        q
    });
    // the weighted squared error of sorted codes, each value at its nearest code
    let error = |codes: &[i16]| {
        let nearest = nearest_code(codes);
        v.iter().map(|&(x, w)| w * (x - codes[nearest(x)] as i64).pow(2) as f64).sum::<f64>()
    };
    if error(&quantiles) < error(&even) {
        quantiles
    } else {
        even
    }
}

/// The index of the code nearest a value among sorted `codes`: below the
/// first midpoint between neighbours that lies above the value.
pub(super) fn nearest_code(codes: &[i16]) -> impl Fn(i64) -> usize {
    let mids: Vec<i64> = codes.windows(2).map(|c| (c[0] as i64 + c[1] as i64).div_euclid(2)).collect();
    move |x| mids.partition_point(|&m| m < x)
}

#[cfg(test)]
mod tests {
    use super::coarsen_grid;
    use nerf_infer::format::{Occupancy, Scene};
    use nerf_infer::sampling::hash32;

    /// A coarse cell is occupied where any fine cell it covers is: every
    /// point occupied in a sparse random 16³ grid is occupied in its 4³
    /// coarsening, which stays sparse; 3 (not a divisor of 16) is refused.
    #[test]
    fn a_coarsened_grid_keeps_every_occupied_point() {
        let cfg = crate::config::TrainConfig::fast().with(|c| c.sampling.n_fine = None);
        let mut m = super::random_model(&cfg, Scene::blender(1.0, 2.0, 6.0), 3, 6.0).unwrap();
        let bits: Vec<u8> = (0..512u32).map(|i| hash32(i).is_multiple_of(16) as u8).collect();
        m.grid = Some((16, bits));
        let fine = m.clone();
        coarsen_grid(&mut m, 4).unwrap();
        assert_eq!(m.grid.as_ref().unwrap().1.len(), 8);
        assert!(coarsen_grid(&mut m.clone(), 3).is_err());
        let (f, c) = (fine.grid.as_ref().unwrap(), m.grid.as_ref().unwrap());
        let (f, c) = (Occupancy { res: f.0, bits: &f.1 }, Occupancy { res: c.0, bits: &c.1 });
        let mut both = 0;
        for k in 0..20_000u32 {
            let h = |j: u32| (hash32(k * 3 + j) >> 8) as f32 / (1 << 23) as f32 - 1.0;
            let p = [h(0), h(1), h(2)];
            if f.at_f32(p) {
                assert!(c.at_f32(p), "{p:?} occupied in the fine grid, clear in the coarse one");
                both += 1;
            }
        }
        assert!(both > 50 && c.occupied_cells() < 40, "{both} {}", c.occupied_cells());
    }
}
