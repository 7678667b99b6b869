//! Quantisation to int16 or int8: per-channel weight scales, activation
//! scales from calibration, requantisation constants.

use super::*;

/// Input scale of every column of layer `i`, and the output target factor.
pub(super) fn layer_scales(
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

pub(super) fn quantise_network(
    m: &Model<'_>,
    net: &Network<'_>,
    scheme: Scheme,
    act_bits: u8,
    grid_frac: u8,
    eight_bit: &[usize],
) -> Result<OwnedNetwork, Error> {
    let qmax = match (scheme, act_bits) {
        (Scheme::I16, 16) => 32767.0,
        (Scheme::I8, 16 | 8) => 127.0,
        (Scheme::F32, _) => return Err(ExportError::NotQuantised.into()),
        _ => return Err(ExportError::ActivationBits { act_bits }.into()),
    };
    let t = &m.topology;
    let (view, colour) = (t.view_dependent.then(|| sigma_layer(t) + 2), net.layers.len() - 1);
    let density = sigma_layer(t);
    let (mut layers, mut precise) = (Vec::new(), OwnedPrecise::default());
    for (i, l) in net.layers.iter().enumerate() {
        let (cols, target) = layer_scales(t, &m.encoding, net, i, act_bits, grid_frac);
        debug_assert_eq!(cols.len(), l.in_dim as usize);
        if let Some(bad) = cols.iter().chain(&[target]).find(|v| !v.is_finite() || **v <= 0.0) {
            return Err(ExportError::ActivationRange { layer: i, scale: *bad }.into());
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
pub(super) struct Quantised {
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
pub(super) fn quantise_layer(l: &Layer<'_>, cols: &[f64], target: f64, qmax: f64) -> Quantised {
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
pub(super) fn fine_rows(l: &Layer<'_>, cols: &[f64], q: &Quantised, nd: usize) -> Vec<u8> {
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

/// Hidden-activation bits of an integer model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum ActBits {
    /// i16 activations.
    #[default]
    #[cfg_attr(feature = "clap", value(name = "16"))]
    A16,
    /// u8 ReLU outputs and an i8 feature layer (int8 weights only).
    #[cfg_attr(feature = "clap", value(name = "8"))]
    A8,
}

impl ActBits {
    /// Bits per activation (16 or 8).
    pub fn bits(self) -> u8 {
        match self {
            ActBits::A16 => 16,
            ActBits::A8 => 8,
        }
    }
}

/// How [`quantise_with`] quantises an f32 model.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Quantisation {
    /// The weights' scheme: int16 or int8.
    pub scheme: Scheme,
    /// Hidden activations: 16 bits, or 8 with int8 weights (the encoding
    /// stays Q15).
    pub act_bits: ActBits,
    /// Layers (indices in each network, in file order: trunk, density
    /// head, then the feature, view and colour layers) whose weights are
    /// rounded to int8 precision (±127 steps per output) inside an int16
    /// model: the int8 model's values for those layers, so listing every
    /// layer renders exactly as the int8 export does. Finds the layers
    /// whose 8-bit weights cost PSNR.
    pub eight_bit_layers: Vec<usize>,
}

impl Quantisation {
    /// `scheme` with 16-bit activations and no layer rounded to 8 bits.
    pub fn new(scheme: Scheme) -> Self {
        Self { scheme, act_bits: ActBits::A16, eight_bit_layers: Vec::new() }
    }

    /// The same with `act_bits` activations.
    pub fn with_act_bits(self, act_bits: ActBits) -> Self {
        Self { act_bits, ..self }
    }
}

/// Quantises an f32 model to `scheme` (int16 or int8 weights, 16-bit
/// activations), using the activation ranges stored in the model.
pub fn quantise(m: &Model<'_>, scheme: Scheme) -> Result<OwnedModel, Error> {
    quantise_with(m, &Quantisation::new(scheme))
}

/// Quantises an f32 model as `q` says.
pub fn quantise_with(m: &Model<'_>, q: &Quantisation) -> Result<OwnedModel, Error> {
    let (scheme, act_bits, eight_bit) = (q.scheme, q.act_bits.bits(), &q.eight_bit_layers[..]);
    if m.scheme() != Scheme::F32 {
        return Err(ExportError::AlreadyQuantised.into());
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
pub(super) fn quantise_features(f: &FeatureGrid<'_>) -> (FeatureGrid<'static>, Vec<u8>) {
    let vals: Vec<f32> = (0..f.values()).map(|k| read_f32(f.table, k)).collect();
    let max = vals.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    let frac = frac_bits_for(max, 15);
    let table = vals
        .iter()
        .flat_map(|v| ((*v as f64 * 2f64.powi(frac as i32)).round().clamp(-32767.0, 32767.0) as i16).to_le_bytes())
        .collect();
    let mut shape = f.with_table(&[]);
    shape.frac_bits = frac;
    (shape, table)
}
