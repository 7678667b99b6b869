//! Pruning at export: neurons never active on the calibration rays leave
//! the model, which then renders exactly what the full one does, in fewer
//! bytes, as format version 2.

mod support;

use nerf_infer::format::{prunable, Scheme};
use nerf_infer::Model;
use nerf_infer::Orbit;
use nerf_train::export::{quantise, trainer_model, OwnedModel, Prune};
use nerf_train::path::orbit_rays;
use nerf_train::train::Trainer;
use support::{psnr, render, small_config, unit_scene};

/// Trunk layer whose outputs are killed, and how many of them.
const DEAD_LAYER: usize = 1;
const DEAD: usize = 40;
/// View-layer outputs killed.
const DEAD_VIEW: usize = 20;

/// A 3x64 two-network model (view branch 32 wide) in which the first
/// `DEAD` outputs of trunk layer 1 and the first `DEAD_VIEW` outputs of the
/// view layer can never be positive: zero weights, bias −1.
fn trainer_with_dead_neurons() -> Trainer {
    let cfg = small_config().with(|c| {
        c.model.width = 64;
        c.model.view_width = 32;
    });
    let mut tr = Trainer::new(cfg, unit_scene(), 1, 7).unwrap();
    let mlp = tr.mlp().clone();
    let view = mlp.topo.depth as usize + 2;
    for net in 0..2 {
        let base = net * mlp.n_params;
        for (layer, dead) in [(DEAD_LAYER, DEAD), (view, DEAD_VIEW)] {
            let s = mlp.slots[layer];
            for c in 0..dead {
                for j in 0..s.din {
                    tr.field.params[base + s.w + j * s.dout + c] = 0.0;
                }
                tr.field.params[base + s.b + c] = -1.0;
            }
        }
    }
    tr
}

fn bytes(m: &OwnedModel) -> Vec<u8> {
    m.to_bytes().expect("encode")
}

/// Renders of two orbit views (not the calibration rays' turns).
fn renders(m: &Model<'_>) -> Vec<Vec<[f32; 3]>> {
    let s = m.scene;
    [0.13f32, 0.61].iter().map(|&turn| render(m, &Orbit::new(&s, None).camera(turn, 20, 20).unwrap())).collect()
}

#[test]
fn dead_neurons_leave_the_model_and_every_render_stays_the_same() {
    let tr = trainer_with_dead_neurons();
    let calib = orbit_rays(&tr.scene, 4, 16);
    let view = tr.cfg.model.depth as usize + 2;
    let [off, tiles, exact] = [Prune::Off, Prune::Tiles, Prune::Exact].map(|p| bytes(&trainer_model(&tr, &calib, p)));
    let [off, tiles, exact] = [&off, &tiles, &exact].map(|b| Model::from_bytes(b).expect("decode"));

    // widths: `Tiles` keeps whole groups of 32, `Exact` only the live ones
    for n in [&tiles.coarse, tiles.fine.as_ref().unwrap()] {
        assert_eq!(n.layers[DEAD_LAYER].out_dim, 32, "64 wide, at most 24 live: one tile");
        assert_eq!(n.layers[view].out_dim, 32, "32 wide: stays whole");
        assert_eq!(n.layers[DEAD_LAYER + 1].in_dim as usize, 32 + tr.cfg.encoding().pos_dim(), "skip layer reads it");
    }
    for n in [&exact.coarse, exact.fine.as_ref().unwrap()] {
        assert!(n.layers[DEAD_LAYER].out_dim as usize <= 64 - DEAD);
        assert!(n.layers[view].out_dim as usize <= 32 - DEAD_VIEW);
        for (i, l) in n.layers.iter().enumerate() {
            if !prunable(&exact.topology, i) {
                assert_eq!(l.out_dim, off.coarse.layers[i].out_dim, "layer {i} is not prunable");
            }
        }
    }
    // versions and bytes: nerf info's "before" is the unpruned model's size
    assert!(!off.is_pruned() && tiles.is_pruned() && exact.is_pruned());
    assert_eq!((off.format_version(), tiles.format_version(), exact.format_version()), (1, 2, 2));
    assert!(exact.tensor_bytes() < tiles.tensor_bytes() && tiles.tensor_bytes() < off.tensor_bytes());
    for m in [&tiles, &exact] {
        assert_eq!(m.unpruned_tensor_bytes(), off.tensor_bytes());
    }
    // the removed outputs were 0 everywhere: f32 renders are identical
    let want = renders(&off);
    assert_same(&renders(&tiles), &want, "f32, tiles");
    assert_same(&renders(&exact), &want, "f32, exact");
    // fixed point: the bytes shrink too; the renders match to the last
    // bits (a weight scale can change when a removed input row held a
    // column's largest weight)
    for scheme in [Scheme::I8, Scheme::I16] {
        let q = |m: &Model<'_>| bytes(&quantise(m, scheme).expect("quantise"));
        let [qo, qt, qe] = [q(&off), q(&tiles), q(&exact)];
        let [qo, qt, qe] = [&qo, &qt, &qe].map(|b| Model::from_bytes(b).expect("decode"));
        assert!(qe.tensor_bytes() < qt.tensor_bytes() && qt.tensor_bytes() < qo.tensor_bytes());
        assert_eq!(qe.unpruned_tensor_bytes(), qo.tensor_bytes(), "{scheme:?}");
        let want = renders(&qo);
        for (name, m) in [("tiles", &qt), ("exact", &qe)] {
            let got = renders(m);
            for (g, w) in got.iter().zip(&want) {
                let p = psnr(g, w);
                println!("{scheme:?} {name}: {p:.1} dB vs unpruned");
                assert!(p >= 70.0, "{scheme:?} {name}: {p:.1} dB vs the unpruned render");
            }
        }
    }
}

/// Panics naming the first pixel where two sets of renders differ.
fn assert_same(got: &[Vec<[f32; 3]>], want: &[Vec<[f32; 3]>], what: &str) {
    for (v, (g, w)) in got.iter().zip(want).enumerate() {
        if let Some(i) = (0..w.len()).find(|&i| g[i] != w[i]) {
            panic!("{what}: view {v} pixel {i}: {:?} vs {:?}", g[i], w[i]);
        }
    }
}

#[test]
fn a_version_1_file_cannot_carry_pruned_layers() {
    let tr = trainer_with_dead_neurons();
    let calib = orbit_rays(&tr.scene, 4, 16);
    let v2 = bytes(&trainer_model(&tr, &calib, Prune::Exact));
    assert_eq!(u16::from_le_bytes([v2[4], v2[5]]), 2);
    // the same model written as version 1: no trailing grid byte (None)
    let payload = &v2[14..v2.len() - 1];
    assert_eq!(v2.last(), Some(&0), "no grid");
    let mut v1 = v2[..4].to_vec(); // magic
    v1.extend_from_slice(&1u16.to_le_bytes());
    v1.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    v1.extend_from_slice(&nerf_infer::format::crc32(payload).to_le_bytes());
    v1.extend_from_slice(payload);
    match Model::from_bytes(&v1) {
        Err(e) => assert!(e.to_string().contains("pruned"), "{e}"),
        Ok(_) => panic!("a version-1 file with pruned layers was accepted"),
    }
    // unpruned, the same rewrite decodes
    let full = bytes(&trainer_model(&tr, &calib, Prune::Off));
    assert_eq!(u16::from_le_bytes([full[4], full[5]]), 1);
    Model::from_bytes(&full).expect("version 1 without pruning");
}
