//! Writing model files: the f32 model of a training run, and its int16 /
//! int8 quantisation for the kernel's fixed-point path.
//!
//! Quantisation of a layer `y = W·x + b` whose integer inputs `x_q[j]`
//! stand for `x_q[j]·s_j` (encoding features: `2⁻¹⁵`, raw coordinates:
//! `2^−raw_frac_bits`, hidden activations: `act_max/32767` measured on
//! training rays): the input scales are folded into the weights,
//! `W'[j][c] = W[j][c]·s_j`; each output channel gets its own scale
//! `S[c] = max(maxⱼ|W'[j][c]|/qmax, |b[c]|/2²⁹)`; weights round to
//! `q = round(W'/S)` (ties away from zero) within `±qmax` (32767 or 127)
//! and the bias to `round(b/S)` in i32. The accumulator then holds
//! `y/S[c]`, and the requantisation factor `S[c]/s_out` (or `S[c]·2¹⁰` for
//! the density head, `S[c]·2¹²` for the colour head) becomes a Q0.31
//! multiplier and a shift. The `2²⁹` bias bound keeps int8 layers with up
//! to 355 inputs inside i32: `355·127·2¹⁵ + 2²⁹ < 2³¹`.
//!
//! Three parts of an int8 network are also written at 16 bits: the view
//! layer's direction rows, `round(W'/S · 2⁸)`, summed once per ray, so
//! the 256× finer step costs nothing per sample (their weights are small
//! beside the feature rows', which set `S`, and 8 bits left them a few
//! steps each); the colour head, quantised as in an int16 model (3
//! outputs, evaluated only for samples with weight; both format version
//! 6); and the density head, quantised as in an int16 model (one output;
//! format version 8: 8-bit density weights cost lego at 800×800 3.5 dB).

use crate::mlp::Mlp;
use crate::train::Trainer;
use nerf_infer::features::{FeatureGrid, NarrowTable};
use nerf_infer::fixed::{Requant, ENC_FRAC, LOGIT_FRAC, SIGMA_FRAC};
use nerf_infer::format::{
    self, read_f32, read_i16, sigma_layer, Encoding, Layer, Meta, Model, Network, Samples, Scene, Scheme, Topology,
};
use nerf_infer::network::OUTPUT_TILE;

/// A layer owning its tensor bytes (see [`nerf_infer::format::Layer`]).
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedLayer {
    /// Input width.
    pub in_dim: u16,
    /// Output width.
    pub out_dim: u16,
    /// Largest |output| on calibration rays.
    pub act_max: f32,
    /// Weight bytes.
    pub weights: Vec<u8>,
    /// Bias bytes.
    pub bias: Vec<u8>,
    /// Scale bytes.
    pub scales: Vec<u8>,
    /// Requantisation bytes.
    pub requant: Vec<u8>,
}

/// A network owning its layers.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedNetwork {
    /// Weight scheme.
    pub scheme: Scheme,
    /// Activation bits.
    pub act_bits: u8,
    /// Layers.
    pub layers: Vec<OwnedLayer>,
    /// The parts kept at 16 bits (format version 6; the density head: 8).
    pub precise: Option<OwnedPrecise>,
}

/// A network's 16-bit parts, owned (see [`format::PreciseNet`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OwnedPrecise {
    /// The view layer's direction rows, i16 LE (empty: none).
    pub view_dirs: Vec<u8>,
    /// The colour head with i16 weights.
    pub colour: Option<OwnedLayer>,
    /// The density head with i16 weights (format version 8).
    pub density: Option<OwnedLayer>,
}

impl OwnedLayer {
    fn view(&self) -> Layer<'_> {
        Layer {
            in_dim: self.in_dim,
            out_dim: self.out_dim,
            act_max: self.act_max,
            weights: &self.weights,
            bias: &self.bias,
            scales: &self.scales,
            requant: &self.requant,
        }
    }

    fn from_view(l: &Layer<'_>) -> Self {
        OwnedLayer {
            in_dim: l.in_dim,
            out_dim: l.out_dim,
            act_max: l.act_max,
            weights: l.weights.to_vec(),
            bias: l.bias.to_vec(),
            scales: l.scales.to_vec(),
            requant: l.requant.to_vec(),
        }
    }
}

impl OwnedPrecise {
    fn view(&self) -> format::PreciseNet<'_> {
        format::PreciseNet {
            view_dirs: &self.view_dirs,
            colour: self.colour.as_ref().map(OwnedLayer::view),
            density: self.density.as_ref().map(OwnedLayer::view),
        }
    }

    fn from_view(p: &format::PreciseNet<'_>) -> Self {
        Self {
            view_dirs: p.view_dirs.to_vec(),
            colour: p.colour.as_ref().map(OwnedLayer::from_view),
            density: p.density.as_ref().map(OwnedLayer::from_view),
        }
    }
}

/// A model owning its tensors; [`OwnedModel::to_bytes`] writes the file.
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedModel {
    /// Scene.
    pub scene: Scene,
    /// Encoding.
    pub encoding: Encoding,
    /// Topology.
    pub topology: Topology,
    /// Default samples.
    pub samples: Samples,
    /// Provenance.
    pub meta: Meta,
    /// Coarse network.
    pub coarse: OwnedNetwork,
    /// Fine network.
    pub fine: Option<OwnedNetwork>,
    /// Occupancy grid: cells per axis and the bits (format version 2).
    pub grid: Option<(u16, Vec<u8>)>,
    /// Learned feature grid (format version 3): its shape (`table` empty)
    /// and the table bytes (f32 LE, or i16 LE in quantised models).
    pub features: Option<(FeatureGrid<'static>, Vec<u8>)>,
    /// How the training capture was split and framed (format version 4).
    pub capture: Option<format::Capture>,
    /// The feature table's index bits and codebook bytes when its values
    /// are codebook indices (format version 7, [`NarrowTable`]).
    pub narrow: Option<(u8, Vec<u8>)>,
    /// The orbit fitted to the training cameras (format version 9).
    pub orbit: Option<format::FittedOrbit>,
    /// Features averaged over each sample's pixel footprint (format
    /// version 10).
    pub footprint: Option<format::Footprint>,
    /// The proposal grid (format version 11): its shape and scale
    /// (`codes` empty) and the codes.
    pub proposal: Option<(format::Proposal<'static>, Vec<u8>)>,
}

/// `shape` with `table` as its table (i16 or f32 values; no codebook).
fn with_table<'a>(shape: &FeatureGrid<'_>, table: &'a [u8]) -> FeatureGrid<'a> {
    FeatureGrid {
        width: shape.width,
        log2_table: shape.log2_table,
        frac_bits: shape.frac_bits,
        resolutions: shape.resolutions.clone(),
        table,
        narrow: None,
    }
}

impl OwnedNetwork {
    fn view(&self) -> Network<'_> {
        let mut layers = heapless::Vec::new();
        for l in &self.layers {
            let _ = layers.push(l.view());
        }
        let precise = self.precise.as_ref().map(OwnedPrecise::view);
        Network { scheme: self.scheme, act_bits: self.act_bits, layers, precise }
    }

    fn from_view(n: &Network<'_>) -> Self {
        let layers = n.layers.iter().map(OwnedLayer::from_view).collect();
        let precise = n.precise.as_ref().map(OwnedPrecise::from_view);
        Self { scheme: n.scheme, act_bits: n.act_bits, layers, precise }
    }
}

impl OwnedModel {
    /// The file bytes (validated by the same code that loads them).
    pub fn to_bytes(&self) -> Result<Vec<u8>, nerf_infer::Error> {
        if self.coarse.layers.len() > format::MAX_LAYERS {
            return Err(nerf_infer::Error::Capacity("more than 24 layers"));
        }
        let narrow = self.narrow.as_ref().map(|(bits, codebook)| NarrowTable { bits: *bits, codebook });
        let m = Model {
            scene: self.scene,
            encoding: self.encoding,
            topology: self.topology,
            samples: self.samples,
            meta: self.meta,
            coarse: self.coarse.view(),
            fine: self.fine.as_ref().map(|f| f.view()),
            grid: self.grid.as_ref().map(|(res, bits)| format::Occupancy { res: *res, bits }),
            features: self.features.as_ref().map(|(f, t)| FeatureGrid { narrow, ..with_table(f, t) }),
            capture: self.capture,
            unbounded: self.scene.unbounded,
            precise: self.coarse.precise.as_ref().map(|p| format::Precise {
                coarse: p.view(),
                fine: self.fine.as_ref().and_then(|f| f.precise.as_ref()).map(OwnedPrecise::view),
            }),
            narrow,
            precise_density: self.coarse.precise.as_ref().and_then(|p| p.density.as_ref()).map(|d| {
                format::PreciseDensity {
                    coarse: d.view(),
                    fine: self.fine.as_ref().and_then(|f| f.precise.as_ref()?.density.as_ref()).map(OwnedLayer::view),
                }
            }),
            orbit: self.orbit,
            footprint: self.footprint,
            proposal: self.proposal.as_ref().map(|(p, codes)| format::Proposal { codes, ..*p }),
        };
        format::to_bytes(&m)
    }

    /// An owned copy of a decoded model.
    pub fn from_model(m: &Model<'_>) -> Self {
        Self {
            scene: m.scene,
            encoding: m.encoding,
            topology: m.topology,
            samples: m.samples,
            meta: m.meta,
            coarse: OwnedNetwork::from_view(&m.coarse),
            fine: m.fine.as_ref().map(OwnedNetwork::from_view),
            grid: m.grid.map(|g| (g.res, g.bits.to_vec())),
            features: m.features.as_ref().map(|f| (with_table(f, &[]), f.table.to_vec())),
            capture: m.capture,
            narrow: m.narrow.map(|n| (n.bits, n.codebook.to_vec())),
            orbit: m.orbit,
            footprint: m.footprint,
            proposal: m.proposal.map(|p| (format::Proposal { codes: &[], ..p }, p.codes.to_vec())),
        }
    }
}

fn f32_bytes(v: impl IntoIterator<Item = f32>) -> Vec<u8> {
    v.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// The f32 network of a parameter vector laid out by `mlp`.
pub fn f32_network(mlp: &Mlp, params: &[f32], act_max: &[f32]) -> OwnedNetwork {
    let layers = mlp
        .slots
        .iter()
        .enumerate()
        .map(|(i, s)| OwnedLayer {
            in_dim: s.din as u16,
            out_dim: s.dout as u16,
            act_max: act_max.get(i).copied().unwrap_or(0.0),
            weights: f32_bytes(params[s.w..s.b].iter().copied()),
            bias: f32_bytes(params[s.b..s.b + s.dout].iter().copied()),
            scales: Vec::new(),
            requant: Vec::new(),
        })
        .collect();
    OwnedNetwork { scheme: Scheme::F32, act_bits: 32, layers, precise: None }
}

/// Fractional bits for raw coordinates whose magnitude reaches `max_abs`
/// (with 5 % headroom), in `0..=14`.
pub fn raw_frac_bits_for(max_abs: f32) -> u8 {
    frac_bits_for(max_abs, 14)
}

/// Most fractional bits (≤ `cap`) that keep `max_abs` (with 5 % headroom)
/// inside i16.
fn frac_bits_for(max_abs: f32, cap: u8) -> u8 {
    let m = (max_abs.abs() * 1.05).max(1e-3) as f64;
    (32767.0 / m).log2().floor().clamp(0.0, cap as f64) as u8
}

/// The f32 model of a run (of its parameters' average when it keeps one,
/// [`Trainer::averaged`]), with activation ranges from `calibration` rays
/// (drawn from the training views).
/// `prune` says which never-active neurons are removed (see [`Prune`]).
pub fn trainer_model(tr: &Trainer, calibration: &[crate::train::Sample], prune: Prune) -> OwnedModel {
    let tr = &*tr.averaged();
    let mlp = tr.mlp();
    let cal = tr.calibrate(calibration);
    let mut encoding = tr.cfg.encoding();
    encoding.raw_frac_bits = raw_frac_bits_for(cal.max_pos);
    let t = tr.cfg.topology();
    let coarse = f32_network(&mlp, tr.coarse_params(), &cal.max_c);
    let coarse = prune_network(&t, &encoding, &coarse, &cal.active_c, prune);
    let fine = tr.fine_params().map(|p| {
        let net = f32_network(&mlp, p, cal.max_f.as_deref().unwrap_or(&[]));
        prune_network(&t, &encoding, &net, cal.active_f.as_deref().unwrap_or(&[]), prune)
    });
    OwnedModel {
        scene: tr.scene,
        encoding,
        topology: t,
        samples: tr.cfg.samples(),
        meta: Meta { train_downscale: tr.downscale as u16, iterations: tr.step as u32 },
        coarse,
        fine,
        grid: tr.grid.as_ref().map(|g| (g.res, g.bits.clone())),
        features: mlp
            .features
            .as_ref()
            .map(|f| (f.clone(), f32_bytes(tr.params[mlp.table..mlp.n_params].iter().copied()))),
        capture: None,
        narrow: None,
        orbit: None,
        footprint: tr.footprint().filter(|_| tr.scene.ndc.is_none()),
        proposal: tr.proposal.as_ref().map(|g| {
            let (log_min, log_step, codes) = g.codes();
            (format::Proposal { res: g.res, log_min, log_step, codes: &[] }, codes)
        }),
    }
}

/// Which neurons never active on the calibration rays the exported model
/// drops (`nerf train --prune`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Prune {
    /// Keep every neuron.
    Off,
    /// Drop dead neurons in whole groups of [`OUTPUT_TILE`] (32): a layer
    /// at least that wide keeps a multiple of it, padded with dead
    /// neurons, so the kernels run only whole register tiles. Narrower
    /// layers are pruned exactly.
    Tiles,
    /// Drop every dead neuron: fewest bytes, but widths off the tile grain
    /// take the kernels' slower remainder loop (2.2x the µs per ray on the
    /// lego grid model with AVX-512; no difference on Cortex-M).
    Exact,
}

/// The outputs of a layer `old` wide to keep, given which were active.
fn kept_outputs(act: &[bool], old: usize, prune: Prune) -> Vec<usize> {
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
fn keep_columns(l: &mut OwnedLayer, keep: &[usize]) {
    let (din, dout) = (l.in_dim as usize, l.out_dim as usize);
    let w = |j: usize, c: usize| read_f32(&l.weights, j * dout + c);
    l.weights = f32_bytes((0..din).flat_map(|j| keep.iter().map(move |&c| w(j, c))).collect::<Vec<_>>());
    l.bias = f32_bytes(keep.iter().map(|&c| read_f32(&l.bias, c)).collect::<Vec<_>>());
    l.out_dim = keep.len() as u16;
}

/// Keeps, of the `n` input rows starting at `off`, the rows `off + keep[k]`
/// (all rows outside that range stay).
fn keep_rows(l: &mut OwnedLayer, off: usize, n: usize, keep: &[usize]) {
    let (din, dout) = (l.in_dim as usize, l.out_dim as usize);
    let rows: Vec<usize> = (0..off).chain(keep.iter().map(|&c| off + c)).chain(off + n..din).collect();
    let w = |j: usize, c: usize| read_f32(&l.weights, j * dout + c);
    l.weights = f32_bytes(rows.iter().flat_map(|&j| (0..dout).map(move |c| w(j, c))).collect::<Vec<_>>());
    l.in_dim = rows.len() as u16;
}

/// Input scale of every column of layer `i`, and the output target factor.
fn layer_scales(
    t: &Topology,
    e: &Encoding,
    net: &Network<'_>,
    i: usize,
    act_bits: u8,
    grid_frac: u8,
) -> (Vec<f64>, f64) {
    // largest code of layer l's output: i16, or u8 after ReLU / i8 for the
    // linear feature layer
    let linear = |l: usize| t.view_dependent && l == sigma_layer(t) + 1;
    let top = |l: usize| match (act_bits, linear(l)) {
        (8, false) => 255.0,
        (8, true) => 127.0,
        _ => 32767.0,
    };
    let act = |l: usize| (net.layers[l].act_max.max(1e-6) as f64) / top(l);
    let enc = |freqs: u8| {
        let mut v = Vec::new();
        if e.include_input {
            v.extend([2f64.powi(-(e.raw_frac_bits as i32)); 3]);
        }
        v.extend(std::iter::repeat_n(2f64.powi(-(ENC_FRAC as i32)), 6 * freqs as usize));
        v
    };
    let out = |l: usize| net.layers[l].out_dim as usize; // pruned layers are narrower
    let d = t.depth as usize;
    let si = sigma_layer(t);
    let hidden = |l: usize| vec![act(l); out(l)];
    if i < d {
        let mut cols = Vec::new();
        if i == 0 || t.is_skip(i) {
            cols.extend(enc(e.pos_freqs));
            cols.extend(std::iter::repeat_n(2f64.powi(-(grid_frac as i32)), e.grid_dim as usize));
        }
        if i > 0 {
            cols.extend(hidden(i - 1));
        }
        return (cols, 1.0 / act(i));
    }
    match (i - si, t.view_dependent) {
        (0, _) => (hidden(d - 1), 2f64.powi(SIGMA_FRAC as i32)),
        (1, true) => (hidden(d - 1), 1.0 / act(i)),
        (2, true) => {
            let mut cols = hidden(si + 1);
            cols.extend(enc(e.dir_freqs));
            (cols, 1.0 / act(i))
        }
        (3, true) => (hidden(si + 2), 2f64.powi(LOGIT_FRAC as i32)),
        _ => (hidden(d - 1), 2f64.powi(LOGIT_FRAC as i32)),
    }
}

fn quantise_network(
    m: &Model<'_>,
    net: &Network<'_>,
    scheme: Scheme,
    act_bits: u8,
    grid_frac: u8,
    eight_bit: &[usize],
) -> Result<OwnedNetwork, String> {
    let qmax = match (scheme, act_bits) {
        (Scheme::I16, 16) => 32767.0,
        (Scheme::I8, 16 | 8) => 127.0,
        (Scheme::F32, _) => return Err("quantise to int16 or int8".into()),
        _ => return Err(format!("{act_bits}-bit activations need int8 weights")),
    };
    let t = &m.topology;
    let (view, colour) = (t.view_dependent.then(|| sigma_layer(t) + 2), net.layers.len() - 1);
    let density = sigma_layer(t);
    let (mut layers, mut precise) = (Vec::new(), OwnedPrecise::default());
    for (i, l) in net.layers.iter().enumerate() {
        let (cols, target) = layer_scales(t, &m.encoding, net, i, act_bits, grid_frac);
        debug_assert_eq!(cols.len(), l.in_dim as usize);
        if let Some(bad) = cols.iter().chain(&[target]).find(|v| !v.is_finite() || **v <= 0.0) {
            return Err(format!(
                "layer {i}: activation range is not finite or not positive (scale {bad}): the model's calibration \
                 saw non-finite activations; retrain or export at 32 bits"
            ));
        }
        // int8 precision, as in the int8 model: 8-bit steps plus the 16-bit
        // parts (the view layer's direction rows, 16-bit colour and density
        // heads)
        let eight = qmax == 127.0 || eight_bit.contains(&i);
        let q = quantise_layer(l, &cols, target, if eight { 127.0 } else { 32767.0 });
        if eight && i == colour {
            precise.colour = Some(quantise_layer(l, &cols, target, 32767.0).to_layer(2));
        }
        if eight && i == density {
            precise.density = Some(quantise_layer(l, &cols, target, 32767.0).to_layer(2));
        }
        if eight && Some(i) == view {
            precise.view_dirs = fine_rows(l, &cols, &q, m.encoding.dir_dim());
        }
        layers.push(q.to_layer(scheme.weight_bytes()));
    }
    let any = !precise.view_dirs.is_empty() || precise.colour.is_some() || precise.density.is_some();
    Ok(OwnedNetwork { scheme, act_bits, layers, precise: any.then_some(precise) })
}

/// A layer quantised with `±qmax` steps per output channel, before its
/// weights are written at a width.
struct Quantised {
    in_dim: u16,
    out_dim: u16,
    act_max: f32,
    /// Weights in steps, input-major.
    q: Vec<i32>,
    /// Per-channel step `S[c]` (as stored, f32).
    steps: Vec<f64>,
    bias: Vec<u8>,
    requant: Vec<u8>,
}

impl Quantised {
    /// The layer with `bytes`-wide weights (1: i8, 2: i16).
    fn to_layer(&self, bytes: usize) -> OwnedLayer {
        let weights = match bytes {
            2 => self.q.iter().flat_map(|&v| (v as i16).to_le_bytes()).collect(),
            _ => self.q.iter().map(|&v| v as i8 as u8).collect(),
        };
        OwnedLayer {
            in_dim: self.in_dim,
            out_dim: self.out_dim,
            act_max: self.act_max,
            weights,
            bias: self.bias.clone(),
            scales: f32_bytes(self.steps.iter().map(|&s| s as f32)),
            requant: self.requant.clone(),
        }
    }
}

/// Quantises f32 layer `l` whose input `j` has scale `cols[j]` and whose
/// output is wanted in units of `1/target`, with `±qmax` steps per output
/// channel (see the module documentation).
fn quantise_layer(l: &Layer<'_>, cols: &[f64], target: f64, qmax: f64) -> Quantised {
    let (din, dout) = (l.in_dim as usize, l.out_dim as usize);
    let mut q = vec![0i32; din * dout];
    let (mut bias, mut steps, mut requant) = (Vec::new(), Vec::new(), Vec::new());
    for c in 0..dout {
        let w = |j: usize| read_f32(l.weights, j * dout + c) as f64 * cols[j];
        let b = read_f32(l.bias, c) as f64;
        let amax = (0..din).map(|j| w(j).abs()).fold(0.0, f64::max);
        let mut s = (amax / qmax).max(b.abs() / 2f64.powi(29));
        if s == 0.0 {
            s = 1.0;
        }
        let s = s as f32 as f64; // stored as f32: quantise against the stored value
        for j in 0..din {
            q[j * dout + c] = (w(j) / s).round().clamp(-qmax, qmax) as i32;
        }
        bias.extend(((b / s).round() as i32).to_le_bytes());
        steps.push(s);
        // A channel with no weights and no bias outputs exactly 0; one
        // whose calibrated output range is far below a weight step
        // saturates (the largest factor), one far above it rounds to 0.
        let factor = if amax == 0.0 && b == 0.0 { 0.0 } else { s * target };
        let r = Requant::from_f64(factor).unwrap_or(if factor > 1.0 {
            Requant { multiplier: i32::MAX, shift: Requant::MIN_SHIFT }
        } else {
            Requant { multiplier: 0, shift: 0 }
        });
        debug_assert!(r.is_valid(), "channel {c}: {r:?}");
        requant.extend(r.multiplier.to_le_bytes());
        requant.extend(r.shift.to_le_bytes());
    }
    Quantised { in_dim: l.in_dim, out_dim: l.out_dim, act_max: l.act_max, q, steps, bias, requant }
}

/// The last `nd` rows of view layer `l` (the direction's) at 16 bits, in
/// 2^−SHIFT steps of `q`'s channel steps ([`format::PreciseNet`]), i16 LE.
fn fine_rows(l: &Layer<'_>, cols: &[f64], q: &Quantised, nd: usize) -> Vec<u8> {
    let (din, dout) = (l.in_dim as usize, l.out_dim as usize);
    let mut rows = vec![0i16; nd * dout];
    for c in 0..dout {
        let step = q.steps[c] / f64::from(1u32 << format::PreciseNet::SHIFT);
        for k in 0..nd {
            let j = din - nd + k;
            let w = read_f32(l.weights, j * dout + c) as f64 * cols[j];
            rows[k * dout + c] = (w / step).round().clamp(-32767.0, 32767.0) as i16;
        }
    }
    rows.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Quantises an f32 model to `scheme` (int16 or int8 weights, 16-bit
/// activations), using the activation ranges stored in the model.
pub fn quantise(m: &Model<'_>, scheme: Scheme) -> Result<OwnedModel, String> {
    quantise_acts(m, scheme, 16)
}

/// [`quantise`] with `act_bits`-bit hidden activations: 16, or 8 with int8
/// weights (ReLU outputs u8, the feature layer i8; the encoding stays Q15).
pub fn quantise_acts(m: &Model<'_>, scheme: Scheme, act_bits: u8) -> Result<OwnedModel, String> {
    quantise_layers(m, scheme, act_bits, &[])
}

/// [`quantise_acts`] with the weights of layers `eight_bit` (indices in
/// each network, in file order: trunk, density head, then the feature, view
/// and colour layers) rounded to int8 precision (±127 steps per output)
/// inside an int16 model: the int8 model's values for those layers, so
/// listing every layer renders exactly as the int8 export does. Finds the
/// layers whose 8-bit weights cost PSNR.
pub fn quantise_layers(m: &Model<'_>, scheme: Scheme, act_bits: u8, eight_bit: &[usize]) -> Result<OwnedModel, String> {
    if m.scheme() != Scheme::F32 {
        return Err("the model is already quantised; export from the f32 model".into());
    }
    let mut out = OwnedModel::from_model(m);
    out.features = m.features.as_ref().map(quantise_features);
    let grid_frac = out.features.as_ref().map_or(0, |(f, _)| f.frac_bits);
    out.coarse = quantise_network(m, &m.coarse, scheme, act_bits, grid_frac, eight_bit)?;
    out.fine = match &m.fine {
        Some(f) => Some(quantise_network(m, f, scheme, act_bits, grid_frac, eight_bit)?),
        None => None,
    };
    Ok(out)
}

/// The f32 feature table as i16 with the most fractional bits (≤ 15) that
/// keep its largest |value| (with 5 % headroom) in range; round to nearest.
fn quantise_features(f: &FeatureGrid<'_>) -> (FeatureGrid<'static>, Vec<u8>) {
    let vals: Vec<f32> = (0..f.values()).map(|k| read_f32(f.table, k)).collect();
    let max = vals.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let frac = frac_bits_for(max, 15);
    let table = vals
        .iter()
        .flat_map(|v| ((*v as f64 * 2f64.powi(frac as i32)).round().clamp(-32767.0, 32767.0) as i16).to_le_bytes())
        .collect();
    let mut shape = with_table(f, &[]);
    shape.frac_bits = frac;
    (shape, table)
}

/// The occupancy grid of `m` coarsened to `res` cells per axis (a divisor
/// of the model's resolution): a coarse cell is occupied if any of the
/// fine cells it covers is, so nothing occupied is ever skipped; only
/// more empty space is sampled. Bits shrink by `(old/res)³`.
pub fn coarsen_grid(m: &mut OwnedModel, res: u16) -> Result<(), String> {
    let Some((old, bits)) = &m.grid else {
        return Err("the model has no occupancy grid".into());
    };
    let (old, new) = (*old as usize, res as usize);
    if new == 0 || new > old || old % new != 0 {
        return Err(format!("--grid-res {res} must divide the model's grid resolution {old}"));
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

/// The feature table of an integer model stored as `bits`-bit (8 or 4)
/// indices into a codebook of `2^bits` i16 values per level (format
/// version 7, [`NarrowTable`]). Each level's codebook is the Lloyd–Max
/// quantiser of its values, each value weighted by how much a lattice of
/// points in the occupancy grid's occupied cells reads it (the samples a
/// render evaluates): 1-D k-means from the better of two starts (even
/// codes over the values' range, their weighted quantiles), a local least
/// weighted squared error, so the codes go where the values that reach
/// the pixels are. Each value stores its nearest code; the table is padded
/// to whole 4-byte words.
pub fn narrow_table(m: &mut OwnedModel, bits: u8) -> Result<(), String> {
    if !m.coarse.scheme.is_fixed() {
        return Err("a narrow feature table needs an integer model (--bits 16 or 8)".into());
    }
    if !matches!(bits, 4 | 8) {
        return Err(format!("{bits}-bit table indices: 8 or 4 (16 is the i16 table)"));
    }
    let Some((shape, table)) = &mut m.features else {
        return Err("the model has no feature grid".into());
    };
    if m.narrow.is_some() {
        return Err("the feature table is already narrow".into());
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
fn value_weights(shape: &FeatureGrid<'_>, grid: Option<&(u16, Vec<u8>)>) -> Vec<f64> {
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
fn lloyd_max(values: &[i16], weights: &[f64], k: usize) -> Vec<i16> {
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
fn nearest_code(codes: &[i16]) -> impl Fn(i64) -> usize {
    let mids: Vec<i64> = codes.windows(2).map(|c| (c[0] as i64 + c[1] as i64).div_euclid(2)).collect();
    move |x| mids.partition_point(|&m| m < x)
}

/// A model with random weights for tests and benchmarks: He-uniform
/// weights (PyTorch's default scaled by √6, so activations keep their
/// magnitude through the layers and the image has structure), the density
/// head further scaled by `sigma_gain`; activation ranges calibrated on
/// rays of an orbit around the scene (twice those with a feature grid,
/// whose random table is noise); feature-grid values uniform in ±0.5.
pub fn random_model(cfg: &crate::config::TrainConfig, scene: Scene, seed: u64, sigma_gain: f32) -> OwnedModel {
    let mut tr = Trainer::new(cfg.clone(), scene, 1, seed);
    let mlp = tr.mlp();
    let si = sigma_layer(&mlp.topo);
    let nets = if cfg.n_fine > 0 { 2 } else { 1 };
    for k in 0..nets {
        let off = k * mlp.n_params;
        // the random density head of every scene (an unbounded scene's
        // trainer starts with an even density, no head to scale)
        let init = mlp.init(crate::train::network_seed(seed, k));
        tr.params[off..off + mlp.n_params].copy_from_slice(&init);
        for (i, s) in mlp.slots.iter().enumerate() {
            let gain = if i == si { 6f32.sqrt() * sigma_gain } else { 6f32.sqrt() };
            for v in &mut tr.params[off + s.w..off + s.b] {
                *v *= gain;
            }
        }
    }
    // feature values of the size trained grids reach (init is ±1e-4)
    let mut rng = crate::rng::Rng::new(seed ^ 0xFEA7);
    for v in &mut tr.params[mlp.table..mlp.n_params] {
        *v = rng.f32() - 0.5;
    }
    let rays = crate::path::orbit_rays(&scene, 8, 24);
    let mut m = trainer_model(&tr, &rays, Prune::Off);
    if m.features.is_some() {
        // a random table is noise: points between the calibration rays
        // reach beyond the calibrated activation ranges (seen: one pixel of
        // a test view off by 0.64 in int16), so give them 2× headroom
        for l in &mut m.coarse.layers {
            l.act_max *= 2.0;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::{lloyd_max, value_weights};
    use nerf_infer::features::{geometric_resolutions, FeatureGrid};

    fn sse(values: &[i16], codes: &[i16]) -> i64 {
        values.iter().map(|&v| codes.iter().map(|&c| (c as i64 - v as i64).pow(2)).min().unwrap()).sum()
    }

    fn weighted_sse(values: &[i16], weights: &[f64], codes: &[i16]) -> f64 {
        let err = |v: i16| codes.iter().map(|&c| (c as f64 - v as f64).powi(2)).fold(f64::MAX, f64::min);
        values.iter().zip(weights).map(|(&v, &w)| w * err(v)).sum()
    }

    /// Values that count little (weight 10⁻⁴) spread wide around a bunch
    /// that counts: the weighted codes have less weighted error than codes
    /// fitted without the weights, and more of them sit in the bunch.
    #[test]
    fn weights_pull_the_codes_to_the_values_that_count() {
        let values: Vec<i16> = (0..4000i32)
            .map(|i| if i % 2 == 0 { (i * 37 % 401 - 200) as i16 } else { (i * 7919 % 60_001 - 30_000) as i16 })
            .collect();
        let weights: Vec<f64> = (0..4000).map(|i| if i % 2 == 0 { 1.0 } else { 1e-4 }).collect();
        let even = vec![1.0; values.len()];
        let (weighted, plain) = (lloyd_max(&values, &weights, 16), lloyd_max(&values, &even, 16));
        let (a, b) = (weighted_sse(&values, &weights, &weighted), weighted_sse(&values, &weights, &plain));
        println!("weighted error {a:.0} with weighted codes, {b:.0} with plain ones");
        assert!(a < b, "{a} against {b}");
        let in_bunch = |codes: &[i16]| codes.iter().filter(|c| c.abs() <= 200).count();
        println!("codes in the bunch: {} weighted, {} plain", in_bunch(&weighted), in_bunch(&plain));
        assert!(in_bunch(&weighted) > in_bunch(&plain), "{weighted:?} against {plain:?}");
    }

    /// With one occupied cell of a 2³ occupancy grid, the vertices of that
    /// octant (a dense level) take weight; the rest keep only the floor.
    #[test]
    fn value_weights_follow_the_occupied_cells() {
        let shape = FeatureGrid {
            width: 1,
            log2_table: 10,
            frac_bits: 0,
            resolutions: geometric_resolutions(1, 4, 4),
            table: &[],
            narrow: None,
        };
        let grid = (2u16, vec![0b0000_0001u8]); // cell (0, 0, 0): x, y, z < 0
        let w = value_weights(&shape, Some(&grid));
        assert_eq!(w.len(), 125);
        let floor = w.iter().cloned().fold(f64::MAX, f64::min);
        for (e, &v) in w.iter().enumerate() {
            let vertex = [e % 5, e / 5 % 5, e / 25];
            // the octant's cells span vertices 0..=2 per axis
            let inside = vertex.iter().all(|&i| i <= 2);
            assert_eq!(v > floor * 10.0, inside, "vertex {vertex:?}: weight {v} (floor {floor})");
        }
        // without a grid every vertex is read
        let all = value_weights(&shape, None);
        let least = all.iter().cloned().fold(f64::MAX, f64::min);
        assert!(least > 1e-3 * all.iter().sum::<f64>() / 125.0 * 10.0, "{least}");
    }

    /// On values bunched near zero with a long tail (as a trained table's
    /// are), the codebook has less than half the squared error of the even one over
    /// the same range it starts from, keeps the extremes within reach, and
    /// comes out sorted and distinct.
    #[test]
    fn lloyd_max_codes_beat_even_codes_on_a_peaked_distribution() {
        // a Laplace spread of scale 200 (half the values within ±139), tails to ±1 842
        let values: Vec<i16> = (1..20_000i64)
            .map(|i| {
                let u = (i * 7919 % 20_000) as f64 / 20_000.0 - 0.5;
                (-u.signum() * 200.0 * (1.0 - 2.0 * u.abs()).max(1e-7).ln()).clamp(-30_000.0, 30_000.0) as i16
            })
            .collect();
        let (lo, hi) = (*values.iter().min().unwrap() as f64, *values.iter().max().unwrap() as f64);
        for k in [16usize, 256] {
            let codes = lloyd_max(&values, &vec![1.0; values.len()], k);
            assert_eq!(codes.len(), k);
            assert!(codes.windows(2).all(|c| c[0] < c[1]), "{k} codes not sorted and distinct: {codes:?}");
            let even: Vec<i16> =
                (0..k).map(|i| (lo + (hi - lo) * (i as f64 + 0.5) / k as f64).round() as i16).collect();
            let (got, start) = (sse(&values, &codes), sse(&values, &even));
            println!("{k} codes: squared error {got} against {start} with even codes");
            assert!(got * 2 < start, "{k} codes: {got} against {start}");
        }
    }

    /// Fewer distinct values than codes: each value is a code, exactly.
    #[test]
    fn lloyd_max_codes_every_value_of_a_small_set() {
        let values = [-7i16, 3, 3, 3, 100, -7, 12];
        let codes = lloyd_max(&values, &[1.0; 7], 16);
        assert_eq!(sse(&values, &codes), 0, "{codes:?}");
        assert_eq!(lloyd_max(&[], &[], 4), [0; 4]);
    }
}
