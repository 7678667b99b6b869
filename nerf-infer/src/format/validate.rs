//! Validation of a decoded model: every field, every tensor length, every
//! value the kernels rely on.

use super::*;
use crate::error::{Error, Result};
use crate::tensor::read_f32;

impl Model<'_> {
    /// Checks every field; called by [`Model::from_bytes`].
    pub fn validate(&self) -> Result<()> {
        let s = &self.scene;
        let finite3 = |v: &[f32; 3]| v.iter().all(|x| x.is_finite());
        if !finite3(&s.bounds_min) || !finite3(&s.bounds_max) {
            return Err(Error::InvalidScene("bounds are not finite"));
        }
        if (0..3).any(|i| s.bounds_min[i] >= s.bounds_max[i]) {
            return Err(Error::InvalidScene("bounds_min is not below bounds_max"));
        }
        if !(s.near.is_finite() && s.far.is_finite() && s.near >= 0.0 && s.near < s.far) {
            return Err(Error::InvalidScene("need finite 0 <= near < far"));
        }
        if s.far > 30000.0 {
            return Err(Error::InvalidScene("far exceeds the fixed-point range (30000)"));
        }
        if s.unbounded != self.unbounded {
            return Err(Error::InvalidScene("scene.unbounded differs from the model's unbounded field"));
        }
        if let Some(u) = s.unbounded {
            if s.ndc.is_some() || !(u.linear_until.is_finite() && u.linear_until > 0.0 && u.linear_until < s.far) {
                return Err(Error::InvalidScene("unbounded space needs 0 < linear_until < far and no NDC"));
            }
        }
        if let Some(n) = s.ndc {
            let finite = n.focal.is_finite() && n.width.is_finite() && n.height.is_finite();
            if !(finite && n.focal > 0.0 && n.width >= 1.0 && n.height >= 1.0) {
                return Err(Error::InvalidScene("NDC parameters"));
            }
        }
        let e = &self.encoding;
        if e.pos_freqs as usize > MAX_FREQS || e.dir_freqs as usize > MAX_FREQS {
            return Err(Error::InvalidEncoding("more than 16 frequencies"));
        }
        if e.raw_frac_bits > 15 {
            return Err(Error::InvalidEncoding("raw_frac_bits above 15"));
        }
        if e.pos_dim() == 0 || (self.topology.view_dependent && e.dir_dim() == 0) {
            return Err(Error::InvalidEncoding("empty encoding"));
        }
        let t = &self.topology;
        if t.depth == 0 || t.width == 0 || (t.view_dependent && t.view_width == 0) {
            return Err(Error::InvalidTopology("zero depth or width"));
        }
        if t.width as usize > MAX_WIDTH || t.view_width as usize > MAX_WIDTH {
            return Err(Error::Capacity("layer width above 256"));
        }
        if t.layer_count() > MAX_LAYERS {
            return Err(Error::Capacity("more than 24 layers"));
        }
        if t.skip_mask & 1 != 0 || (t.depth < 16 && t.skip_mask >> t.depth != 0) {
            return Err(Error::InvalidTopology("skip mask names a layer outside 1..depth"));
        }
        let sm = &self.samples;
        // importance samples need two bins of weights: three coarse samples
        let least = if sm.fine > 0 { 3 } else { 2 };
        if sm.coarse < least || sm.coarse as usize > max_coarse(sm.fine as usize) || sm.fine as usize > MAX_FINE {
            return Err(Error::InvalidSamples);
        }
        if self.proposal.is_some() {
            // the importance samples and the last stratified one share the fine buffer
            if self.fine.is_some() || sm.fine == 0 || sm.fine as usize >= MAX_FINE {
                return Err(Error::InvalidTopology("a proposal grid needs 1..=255 samples and no fine network"));
            }
            if !self.proposal.is_some_and(|p| p.is_valid()) {
                return Err(Error::InvalidTopology("proposal grid resolution, length or density scale"));
            }
        } else if (sm.fine > 0) != self.fine.is_some() {
            return Err(Error::InvalidTopology("fine samples without a fine network or vice versa"));
        }
        if self.grid.is_some_and(|g| !g.is_valid()) {
            return Err(Error::InvalidTopology("occupancy grid resolution or length"));
        }
        if self.proposal.is_some() && !cfg!(feature = "proposal") {
            return Err(Error::Capacity("proposal grid (nerf-infer built without its `proposal` feature)"));
        }
        if self.features.is_some() && !cfg!(feature = "feature-grid") {
            return Err(Error::Capacity("feature grid (nerf-infer built without its `feature-grid` feature)"));
        }
        if self.narrow != self.features.as_ref().and_then(|f| f.narrow) {
            return Err(Error::InvalidEncoding("the narrow table differs from the feature grid's or has no grid"));
        }
        if self.narrow.is_some() && !self.scheme().is_fixed() {
            return Err(Error::InvalidEncoding("a narrow feature table in an f32 model"));
        }
        let elem = if self.scheme().is_fixed() { 2 } else { 4 };
        if self.features.as_ref().is_some_and(|f| !f.is_valid(elem)) {
            return Err(Error::InvalidEncoding("feature grid shape, range or table length"));
        }
        if self.encoding.grid_dim as usize != self.features.as_ref().map_or(0, |f| f.dim()) {
            return Err(Error::InvalidEncoding("grid_dim does not match the feature grid"));
        }
        if self.capture.is_some_and(|c| c.holdout == 0 || c.holdout > Capture::MAX_HOLDOUT || c.views == 0) {
            return Err(Error::InvalidScene("capture record: holdout outside 1..=100000 or no views"));
        }
        if self.orbit.is_some_and(|o| !o.is_valid()) {
            return Err(Error::InvalidScene(
                "fitted orbit: not finite, up not a unit vector, radius, height (|height| <= 100 radius), fov_x or azimuth out of range",
            ));
        }
        if self.footprint.is_some_and(|f| !f.is_valid()) {
            return Err(Error::InvalidScene("pixel footprint: not finite or outside (0, 0.1] radians"));
        }
        if self.footprint.is_some() && (self.features.is_none() || self.scene.ndc.is_some()) {
            return Err(Error::InvalidScene(
                "a pixel footprint without a feature grid or in a forward-facing (NDC) scene",
            ));
        }
        if self.orbit.is_some() && self.scene.ndc.is_some() {
            return Err(Error::InvalidScene("a fitted orbit in a forward-facing (NDC) scene"));
        }
        self.validate_precise()?;
        self.validate_network(&self.coarse)?;
        if let Some(f) = &self.fine {
            if f.scheme != self.coarse.scheme {
                return Err(Error::MixedScheme(0));
            }
            self.validate_network(f)?;
        }
        Ok(())
    }

    /// The 16-bit parts: only in integer models, the same in the model and
    /// in its networks, each of its network's shapes.
    fn validate_precise(&self) -> Result<()> {
        let nets = core::iter::once(&self.coarse).chain(self.fine.as_ref());
        let Some(p) = self.precise else {
            if nets.into_iter().any(|n| n.precise.is_some()) {
                return Err(Error::InvalidTopology("a network has 16-bit parts the model does not"));
            }
            if self.precise_density.is_some() {
                return Err(Error::InvalidTopology("a 16-bit density head without the other 16-bit parts"));
            }
            return Ok(());
        };
        // the density heads: in both networks or neither, as the record says
        let density_ok = match self.precise_density {
            None => p.coarse.density.is_none() && p.fine.is_none_or(|f| f.density.is_none()),
            Some(d) => {
                p.coarse.density == Some(d.coarse)
                    && match p.fine {
                        Some(f) => d.fine.is_some() && f.density == d.fine,
                        None => d.fine.is_none(),
                    }
            }
        };
        if !density_ok {
            return Err(Error::InvalidTopology("the 16-bit density heads differ from the model's record of them"));
        }
        if !self.scheme().is_fixed() {
            return Err(Error::InvalidTopology("16-bit parts in an f32 model"));
        }
        if self.coarse.precise != Some(p.coarse) || self.fine.as_ref().map(|f| f.precise) != p.fine.map(Some) {
            return Err(Error::InvalidTopology("the networks' 16-bit parts differ from the model's"));
        }
        for n in nets {
            let (Some(pn), Some(last)) = (n.precise, n.layers.last()) else { continue };
            let t = &self.topology;
            let vi = sigma_layer(t) + 2;
            if !pn.view_dirs.is_empty() {
                let od = n.layers.get(vi).filter(|_| t.view_dependent).map_or(0, |l| l.out_dim as usize);
                if pn.view_dirs.len() != self.encoding.dir_dim() * od * 2 {
                    return Err(Error::TensorLength(vi as u8));
                }
            }
            if let Some(c) = pn.colour {
                check_head16(&c, last, 3, n.layers.len() as u8 - 1)?;
            }
            if let Some(d) = pn.density {
                let si = sigma_layer(t);
                // the layer count is checked after the 16-bit parts
                let Some(head) = n.layers.get(si) else { return Err(Error::LayerShape(si as u8)) };
                check_head16(&d, head, 1, si as u8)?;
            }
        }
        Ok(())
    }

    fn validate_network(&self, n: &Network<'_>) -> Result<()> {
        let t = &self.topology;
        let e = &self.encoding;
        if n.layers.len() != t.layer_count() {
            return Err(Error::InvalidTopology("layer count does not match the topology"));
        }
        let act_ok = match n.scheme {
            Scheme::F32 => n.act_bits == 32,
            Scheme::I16 => n.act_bits == 16,
            Scheme::I8 => n.act_bits == 16 || n.act_bits == 8,
        };
        if !act_ok {
            return Err(Error::InvalidTopology("unsupported activation width"));
        }
        for (i, l) in n.layers.iter().enumerate() {
            let (din, dout) = pruned_shape(t, e, &n.layers, i);
            let idx = i as u8;
            let full = expected_shape(t, e, i).1;
            if l.in_dim as usize != din || l.out_dim as usize != dout || dout == 0 || dout > full {
                return Err(Error::LayerShape(idx));
            }
            if !(l.act_max.is_finite() && l.act_max >= 0.0) {
                return Err(Error::InvalidScale(idx));
            }
            let elems = din * dout;
            if l.weights.len() != elems * n.scheme.weight_bytes() || l.bias.len() != 4 * dout {
                return Err(Error::TensorLength(idx));
            }
            if n.scheme.is_fixed() {
                if din > 512 {
                    return Err(Error::Capacity("fixed-point layer input above 512"));
                }
                if l.scales.len() != 4 * dout || l.requant.len() != 8 * dout {
                    return Err(Error::TensorLength(idx));
                }
                for c in 0..dout {
                    let sc = l.scale(c);
                    if !(sc.is_finite() && sc > 0.0 && l.requant(c).is_valid()) {
                        return Err(Error::InvalidScale(idx));
                    }
                }
            } else {
                if !l.scales.is_empty() || !l.requant.is_empty() {
                    return Err(Error::TensorLength(idx));
                }
                let all_finite = (0..elems).all(|k| read_f32(l.weights, k).is_finite())
                    && (0..dout).all(|k| read_f32(l.bias, k).is_finite());
                if !all_finite {
                    return Err(Error::InvalidScale(idx));
                }
            }
        }
        Ok(())
    }
}

/// A 16-bit head `h` read in place of layer `index` (`layer`): its shape
/// (`layer`'s inputs, `outs` outputs), its tensors' lengths (i16 weights,
/// i32 bias, f32 scales, Q0.31 requantisation per output) and its scales.
fn check_head16(h: &Layer<'_>, layer: &Layer<'_>, outs: usize, index: u8) -> Result<()> {
    if h.in_dim != layer.in_dim || h.out_dim as usize != outs {
        return Err(Error::LayerShape(index));
    }
    let lengths = [h.weights.len(), h.bias.len(), h.scales.len(), h.requant.len()];
    if lengths != [h.in_dim as usize * outs * 2, 4 * outs, 4 * outs, 8 * outs] {
        return Err(Error::TensorLength(index));
    }
    if !(h.act_max.is_finite() && h.act_max >= 0.0)
        || (0..outs).any(|k| !(h.scale(k).is_finite() && h.scale(k) > 0.0 && h.requant(k).is_valid()))
    {
        return Err(Error::InvalidScale(index));
    }
    Ok(())
}
