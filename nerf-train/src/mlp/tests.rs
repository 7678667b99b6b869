//! The backward pass against finite differences, with and without a
//! feature grid and footprints; the table scattered chunk by chunk.

use super::*;

fn loss(m: &Mlp, p: &[f32], pos: &[[f32; 3]], foot: &[[f32; 3]], dirs: &[[f32; 3]], a: &mut Acts) -> f64 {
    m.encode_footprint(p, pos, foot, a);
    m.forward_layers(p, dirs, true, a);
    let ls: f64 = a.sigma.iter().enumerate().map(|(i, v)| (*v as f64) * (0.3 + i as f64 * 0.1)).sum();
    let lc: f64 = a.rgb.iter().enumerate().map(|(i, v)| (*v as f64) * ((i % 5) as f64 - 2.0)).sum();
    ls + lc
}

fn check_gradients(topo: Topology, enc: Encoding) {
    check_gradients_with(Mlp::new(topo, enc), false);
}

/// Finite differences against the backward pass; with `footprint`,
/// each sample's features are the mean over three points around it.
fn check_gradients_with(m: Mlp, footprint: bool) {
    let mut p = m.init(3);
    // shift biases so that ReLUs are mostly active away from kinks
    for s in &m.slots {
        for v in &mut p[s.b..s.b + s.dout] {
            *v += 0.05;
        }
    }
    // feature values of the size trained grids reach (init is ±1e-4)
    for (k, v) in p[m.table..].iter_mut().enumerate() {
        *v = (k as f32 * 0.7).sin() * 0.5;
    }
    let pos: Vec<[f32; 3]> = (0..6).map(|i| [0.1 * i as f32, -0.2, 0.05 * i as f32 - 0.1]).collect();
    let dirs = vec![[0.0, 0.6, -0.8], [0.8, 0.0, -0.6]];
    let foot: Vec<[f32; 3]> = match footprint {
        true => pos
            .iter()
            .flat_map(|q| {
                [[0.13, 0.0, 0.02], [-0.07, 0.11, -0.05], [-0.06, -0.11, 0.03]]
                    .map(|o| [q[0] + o[0], q[1] + o[1], q[2] + o[2]])
            })
            .collect(),
        false => Vec::new(),
    };
    let mut a = Acts::default();
    m.encode_footprint(&p, &pos, &foot, &mut a);
    m.forward_layers(&p, &dirs, true, &mut a);
    let ds: Vec<f32> = (0..6).map(|i| 0.3 + i as f32 * 0.1).collect();
    let dc: Vec<f32> = (0..18).map(|i| (i % 5) as f32 - 2.0).collect();
    let mut g = vec![0.0; m.n_params];
    m.backward(&p, &mut a, &ds, &dc, &mut g);
    check_position_gradient(&m, &p, &pos, &foot, &dirs, &ds, &dc);
    // the samples reach table entries of every level (the test must see them)
    if let Some(f) = &m.features {
        for l in 0..f.levels() {
            let w = f.width as usize;
            let level = &g[m.table + f.offset(l) * w..m.table + f.offset(l + 1) * w];
            let touched = level.iter().filter(|v| v.abs() > 1e-3).count();
            assert!(touched >= 8, "{touched} table gradients in level {l}");
        }
    }
    let (mut checked, mut kinks) = (0, 0);
    let fd = |k: usize, h: f32, a: &mut Acts| {
        let mut pp = p.clone();
        pp[k] += h;
        let lp = loss(&m, &pp, &pos, &foot, &dirs, a);
        pp[k] -= 2.0 * h;
        let lm = loss(&m, &pp, &pos, &foot, &dirs, a);
        (lp - lm) / (2.0 * h as f64)
    };
    for k in 0..m.n_params {
        let (f1, f2) = (fd(k, 1e-3, &mut a), fd(k, 5e-4, &mut a));
        let tol = 2e-2 * f1.abs().max(g[k].abs() as f64).max(0.05);
        if (f1 - f2).abs() > tol {
            kinks += 1; // a ReLU switches inside the step: not differentiable there
            continue;
        }
        assert!((f1 - g[k] as f64).abs() <= tol, "param {k}: fd {f1} vs analytic {}", g[k]);
        checked += 1;
    }
    assert!(kinks * 20 < checked, "{kinks} kinks of {checked}");
}

/// [`Mlp::position_gradient`] after a backward pass (of `ds`, `dc`)
/// against finite differences of [`loss`] in each sample's position (γ,
/// and the grid without a footprint) and each footprint point's (the
/// grid), at `pos` and `foot` moved off the grid's faces (where the
/// trilinear blend has a kink).
#[allow(clippy::too_many_arguments)]
fn check_position_gradient(
    m: &Mlp,
    p: &[f32],
    pos: &[[f32; 3]],
    foot: &[[f32; 3]],
    dirs: &[[f32; 3]],
    ds: &[f32],
    dc: &[f32],
) {
    let off = |q: &[f32; 3]| [q[0] + 0.0123, q[1] + 0.0071, q[2] - 0.0047];
    let pos: Vec<[f32; 3]> = pos.iter().map(off).collect();
    let foot: Vec<[f32; 3]> = foot.iter().map(off).collect();
    let (pos, foot) = (&pos[..], &foot[..]);
    let mut a = Acts::default();
    a.keep_input_gradient(true);
    m.encode_footprint(p, pos, foot, &mut a);
    m.forward_layers(p, dirs, true, &mut a);
    m.backward(p, &mut a, ds, dc, &mut vec![0.0; m.n_params]);
    let (mut gamma, mut grid) = (Vec::new(), Vec::new());
    m.position_gradient(p, &a, pos, foot, &mut gamma, &mut grid);
    let mut b = Acts::default();
    let (mut checked, mut kinks) = (0, 0);
    let mut compare = |f1: f64, f2: f64, want: f64, what: &str| {
        let tol = 2e-2 * f1.abs().max(want.abs()).max(0.05);
        if (f1 - f2).abs() > tol {
            kinks += 1; // a ReLU switches, or a point crosses a cell's face, inside the step
            return;
        }
        assert!((f1 - want).abs() <= tol, "{what}: fd {f1} vs analytic {want}");
        checked += 1;
    };
    for i in 0..pos.len() {
        for c in 0..3 {
            let fd = |h: f32, b: &mut Acts| {
                let (mut up, mut down) = (pos.to_vec(), pos.to_vec());
                up[i][c] += h;
                down[i][c] -= h;
                (loss(m, p, &up, foot, dirs, b) - loss(m, p, &down, foot, dirs, b)) / (2.0 * h as f64)
            };
            let grid_part = if foot.is_empty() { grid.get(i).map_or(0.0, |g| g[c]) } else { 0.0 };
            compare(
                fd(1e-3, &mut b),
                fd(5e-4, &mut b),
                (gamma[i][c] + grid_part) as f64,
                &format!("sample {i} axis {c}"),
            );
        }
    }
    for j in 0..foot.len() {
        for c in 0..3 {
            let fd = |h: f32, b: &mut Acts| {
                let (mut up, mut down) = (foot.to_vec(), foot.to_vec());
                up[j][c] += h;
                down[j][c] -= h;
                (loss(m, p, pos, &up, dirs, b) - loss(m, p, pos, &down, dirs, b)) / (2.0 * h as f64)
            };
            compare(fd(1e-3, &mut b), fd(5e-4, &mut b), grid[j][c] as f64, &format!("footprint point {j} axis {c}"));
        }
    }
    let mut dgrad = Vec::new();
    m.direction_gradient(&a, dirs, &mut dgrad);
    assert_eq!(dgrad.len(), if m.topo.view_dependent { dirs.len() } else { 0 });
    for (r, g) in dgrad.iter().enumerate() {
        for c in 0..3 {
            let fd = |h: f32, b: &mut Acts| {
                let (mut up, mut down) = (dirs.to_vec(), dirs.to_vec());
                up[r][c] += h;
                down[r][c] -= h;
                (loss(m, p, pos, foot, &up, b) - loss(m, p, pos, foot, &down, b)) / (2.0 * h as f64)
            };
            compare(fd(1e-3, &mut b), fd(5e-4, &mut b), g[c] as f64, &format!("direction {r} axis {c}"));
        }
    }
    assert!(kinks * 10 < checked, "{kinks} kinks of {checked}");
}

#[test]
fn gradients_match_finite_differences_view_branch_and_skip() {
    let topo = Topology { depth: 3, width: 8, skip_mask: 1 << 2, view_dependent: true, view_width: 4 };
    let enc = Encoding { pos_freqs: 2, dir_freqs: 1, include_input: true, raw_frac_bits: 12, grid_dim: 0 };
    check_gradients(topo, enc);
}

#[test]
fn gradients_match_finite_differences_plain() {
    let topo = Topology { depth: 2, width: 6, skip_mask: 0, view_dependent: false, view_width: 0 };
    let enc = Encoding { pos_freqs: 3, dir_freqs: 0, include_input: false, raw_frac_bits: 12, grid_dim: 0 };
    check_gradients(topo, enc);
}

/// A small network with two dense levels and one hashed of `width`
/// values per entry, a skip layer that also reads them.
fn with_feature_grid(width: u8) -> Mlp {
    let topo = Topology { depth: 3, width: 8, skip_mask: 1 << 2, view_dependent: true, view_width: 4 };
    let f = FeatureGrid {
        width,
        log2_table: 5,
        frac_bits: 0,
        resolutions: nerf_infer::features::geometric_resolutions(3, 1, 5),
        table: &[],
        narrow: None,
    };
    let enc = Encoding { pos_freqs: 1, dir_freqs: 1, include_input: true, raw_frac_bits: 12, grid_dim: 3 * width };
    let m = Mlp::new(topo, enc).with_features(Some(f));
    // levels of 1, 2 and 5 cells: 8 and 27 vertices (dense), 216 > 32 (hashed)
    assert_eq!(m.n_params, m.table + (8 + 27 + 32) * width as usize);
    m
}

#[test]
fn gradients_match_finite_differences_with_a_feature_grid() {
    check_gradients_with(with_feature_grid(2), false);
}

#[test]
fn gradients_match_finite_differences_with_footprint_means_of_the_features() {
    check_gradients_with(with_feature_grid(2), true);
}

#[test]
fn gradients_match_finite_differences_at_feature_widths_3_4_and_8() {
    // the feature loops are compiled once per width: an odd one,
    // another even one and the widest, with and without footprints
    for width in [3, 4, 8] {
        for footprint in [false, true] {
            check_gradients_with(with_feature_grid(width), footprint);
        }
    }
}

#[test]
fn the_table_scattered_from_chunks_equals_the_backward_of_each_chunk_in_turn() {
    scatter_equals_backward(false);
}

#[test]
fn the_table_scattered_from_chunks_with_footprints_equals_their_backward() {
    scatter_equals_backward(true);
}

fn scatter_equals_backward(footprint: bool) {
    let topo = Topology { depth: 2, width: 8, skip_mask: 0, view_dependent: true, view_width: 4 };
    let f = FeatureGrid {
        width: 2,
        log2_table: 6,
        frac_bits: 0,
        resolutions: nerf_infer::features::geometric_resolutions(3, 2, 9),
        table: &[],
        narrow: None,
    };
    let enc = Encoding { pos_freqs: 0, dir_freqs: 1, include_input: true, raw_frac_bits: 12, grid_dim: 6 };
    let m = Mlp::new(topo, enc).with_features(Some(f));
    let mut p = m.init(5);
    for (k, v) in p[m.table..].iter_mut().enumerate() {
        *v = (k as f32 * 0.3).cos() * 0.4;
    }
    let dirs = [[0.0, 0.6, -0.8], [0.8, 0.0, -0.6]];
    let chunks: Vec<Vec<[f32; 3]>> = (0..3)
        .map(|c| (0..8).map(|i| [0.11 * i as f32 - 0.4, 0.07 * c as f32 - 0.2, 0.3 - 0.09 * i as f32]).collect())
        .collect();
    let ds: Vec<f32> = (0..8).map(|i| 0.2 + i as f32 * 0.1).collect();
    let dc: Vec<f32> = (0..24).map(|i| (i % 7) as f32 - 3.0).collect();
    // every chunk's full backward into one gradient, in turn
    let mut whole = vec![0.0; m.n_params];
    let (mut layers, mut grads) = (vec![0.0; m.table], Vec::new());
    let mut a = Acts::default();
    for pos in &chunks {
        let foot: Vec<[f32; 3]> = match footprint {
            true => pos.iter().flat_map(|q| [0.05f32, -0.03, 0.08].map(|o| [q[0] + o, q[1] - o, q[2]])).collect(),
            false => Vec::new(),
        };
        m.encode_footprint(&p, pos, &foot, &mut a);
        m.forward_layers(&p, &dirs, true, &mut a);
        m.backward(&p, &mut a, &ds, &dc, &mut whole);
        m.encode_footprint(&p, pos, &foot, &mut a);
        m.forward_layers(&p, &dirs, true, &mut a);
        m.backward_layers(&p, &mut a, &ds, &dc, &mut layers);
        let mut gg = GridGrad::default();
        m.swap_grid_grad(&mut a, &mut gg);
        grads.push(gg);
    }
    let mut table = vec![0.0; m.n_params - m.table];
    assert!(m.scatter_table(&grads, &mut table), "finite sums reported as such");
    assert!(table.iter().filter(|v| **v != 0.0).count() > 20);
    assert_eq!(&whole[..m.table], &layers[..]);
    assert_eq!(&whole[m.table..], &table[..]);
    // one value infinite, or finite values whose sum overflows f32: reported, and every level still scattered
    let last = grads.len() - 1;
    grads[last].dgf.iter_mut().for_each(|d| *d = f32::MAX);
    let mut big = vec![0.0; table.len()];
    assert!(!m.scatter_table(&grads, &mut big), "an overflowing sum goes unreported");
    grads[last].dgf.iter_mut().for_each(|d| *d = 0.0);
    grads[last].dgf[1] = f32::INFINITY;
    let mut inf = vec![0.0; table.len()];
    assert!(!m.scatter_table(&grads, &mut inf), "an infinite gradient goes unreported");
    // the rest as the other chunks alone make it: only one point's corners (8 entries) differ
    let mut others = vec![0.0; table.len()];
    assert!(m.scatter_table(&grads[..last], &mut others));
    let differ: Vec<f32> = inf.iter().zip(&others).filter(|(a, b)| a != b).map(|(a, _)| *a).collect();
    assert!(!differ.is_empty() && differ.len() <= 8 * 2 && differ.iter().all(|v| !v.is_finite()), "{differ:?}");
}

#[test]
fn samples_dropped_before_the_backward_leave_the_others_gradient() {
    let m = with_feature_grid(2);
    let mut p = m.init(7);
    for (k, v) in p[m.table..].iter_mut().enumerate() {
        *v = (k as f32 * 0.7).sin() * 0.5;
    }
    let pos: Vec<[f32; 3]> = (0..6).map(|i| [0.1 * i as f32, -0.2, 0.05 * i as f32 - 0.1]).collect();
    let keep = [true, false, false, true, true, false];
    // the dropped samples' gradients zero, as a sample without density or weight has
    let ds: Vec<f32> = (0..6).map(|i| if keep[i] { 0.3 + i as f32 * 0.1 } else { 0.0 }).collect();
    let dc: Vec<f32> = (0..18).map(|i| if keep[i / 3] { (i % 5) as f32 - 2.0 } else { 0.0 }).collect();
    for footprint in [false, true] {
        let foot: Vec<[f32; 3]> = match footprint {
            true => pos.iter().flat_map(|q| [0.05f32, -0.03, 0.08].map(|o| [q[0] + o, q[1] - o, q[2]])).collect(),
            false => Vec::new(),
        };
        // a view direction per ray of three samples, and one per sample
        let per_ray = vec![[0.0, 0.6, -0.8], [0.8, 0.0, -0.6]];
        let per_sample: Vec<[f32; 3]> =
            (0..6).map(|i| [0.6, 0.0, -0.8].map(|v: f32| v * (1.0 - 0.1 * i as f32))).collect();
        for dirs in [per_ray, per_sample] {
            let mut a = Acts::default();
            m.encode_footprint(&p, &pos, &foot, &mut a);
            m.forward_layers(&p, &dirs, true, &mut a);
            let mut whole = vec![0.0; m.n_params];
            m.backward(&p, &mut a, &ds, &dc, &mut whole);
            m.encode_footprint(&p, &pos, &foot, &mut a);
            m.forward_layers(&p, &dirs, true, &mut a);
            assert_eq!(a.retain_samples(&m, &keep), 3);
            assert_eq!(a.samples(), 3);
            let (mut ds3, mut dc3) = (ds.clone(), dc.clone());
            retain::retain_rows(&mut ds3, 1, &keep);
            retain::retain_rows(&mut dc3, 3, &keep);
            let mut kept = vec![0.0; m.n_params];
            m.backward(&p, &mut a, &ds3, &dc3, &mut kept);
            assert!(kept[m.table..].iter().filter(|v| **v != 0.0).count() >= 8, "the table reached");
            for (i, (x, y)) in whole.iter().zip(&kept).enumerate() {
                assert!(
                    (x - y).abs() <= 1e-5 * (1.0 + x.abs()),
                    "parameter {i}: {x} against {y} ({footprint}, {dirs:?})"
                );
            }
        }
    }
}
