//! The volume-rendering quadrature (NeRF eq. 3), front to back:
//!
//! `αᵢ = 1 − exp(−σᵢδᵢ)`, `Tᵢ = Πⱼ<ᵢ (1 − αⱼ)`, `wᵢ = Tᵢαᵢ`,
//! `C = Σ wᵢcᵢ + (1 − Σ wᵢ)·background`, `depth = Σ wᵢtᵢ + (1 − Σ wᵢ)·far`.
//!
//! σ is the raw density head output with ReLU applied here (negative or NaN
//! raw values count as 0). The last interval is infinite (the paper's 1e10):
//! any positive density there is opaque. Depth of an empty ray is `far`.
//!
//! Worked example: two samples with α = ½ each on black: T = 1, ½, ¼;
//! weights ½, ¼; opacity ¾.

use crate::fixed::{exp_neg_q26_q30, COLOR_ONE, T_FRAC, T_ONE};
pub use crate::pixel::{to_u8, Pixel, PixelFixed};

/// Front-to-back accumulator of the f32 path.
#[derive(Clone, Copy, Debug)]
pub struct CompositorF32 {
    /// Transmittance before the next sample, `[0, 1]`.
    pub transmittance: f32,
    rgb: [f32; 3],
    opacity: f32,
    depth: f32,
}

impl Default for CompositorF32 {
    fn default() -> Self {
        Self { transmittance: 1.0, rgb: [0.0; 3], opacity: 0.0, depth: 0.0 }
    }
}

/// `α = 1 − exp(−max(σ,0)·δ)` with NaN and 0·∞ mapped to 0, in `[0, 1]`.
#[inline(always)]
pub fn alpha_f32(sigma_raw: f32, delta: f32) -> f32 {
    let sigma = if sigma_raw > 0.0 { sigma_raw } else { 0.0 };
    if sigma == 0.0 || delta <= 0.0 || delta.is_nan() {
        return 0.0;
    }
    let a = 1.0 - libm::expf(-sigma * delta);
    if a.is_nan() {
        1.0
    } else {
        a
    }
}

/// A front-to-back accumulator: what the march composites samples with.
/// `T` is the ray parameter, `S` the raw density, `D` the interval length
/// and `C` the colour, each in its path's format.
pub trait Compositor<T, S, D, C>: Copy + Default {
    /// Weight and transmittance format.
    type W;
    /// The finished pixel.
    type Pixel;
    /// What one sample does to the transmittance, as [`Compositor::add_factor`]
    /// takes it (f32: `α` in `[0, 1]`; fixed point: `exp(−σδ)` in Q30,
    /// `0..=T_ONE`), computed once
    /// per sample: the march works out where a block's ray stops, then adds
    /// the same samples with their colours.
    type Factor: Copy + Default;
    /// Transmittance before the next sample.
    fn transmittance(&self) -> Self::W;
    /// The factor of a sample of raw density `sigma` over an interval `delta`.
    fn factor(sigma: S, delta: D) -> Self::Factor;
    /// Adds a sample at `t` whose factor [`Compositor::factor`] gave and
    /// returns its weight.
    fn add_factor(&mut self, factor: Self::Factor, rgb: C, t: T) -> Self::W;
    /// Adds a sample at `t` and returns its weight.
    #[inline]
    fn add(&mut self, sigma: S, delta: D, rgb: C, t: T) -> Self::W {
        self.add_factor(Self::factor(sigma, delta), rgb, t)
    }
    /// Finishes the ray on the background; `far` is the depth of empty space.
    fn finish(&self, white_background: bool, far: T) -> Self::Pixel;
}

impl Compositor<f32, f32, f32, [f32; 3]> for CompositorF32 {
    type W = f32;
    type Pixel = Pixel;
    type Factor = f32;

    #[inline(always)]
    fn transmittance(&self) -> f32 {
        self.transmittance
    }

    /// `α` ([`alpha_f32`]; `delta` in world units, `f32::INFINITY` for the
    /// last interval).
    #[inline(always)]
    fn factor(sigma_raw: f32, delta: f32) -> f32 {
        alpha_f32(sigma_raw, delta)
    }

    /// Adds one sample of opacity `alpha` (in `[0, 1]`, as [`alpha_f32`]
    /// gives it; colour clamped to `[0, 1]`, NaN read as 0; `t` the
    /// sample's ray parameter) and returns its weight `wᵢ` in `[0, 1]`.
    #[inline]
    fn add_factor(&mut self, alpha: f32, rgb: [f32; 3], t: f32) -> f32 {
        let w = self.transmittance * alpha;
        self.transmittance *= 1.0 - alpha;
        for (acc, c) in self.rgb.iter_mut().zip(rgb) {
            *acc += w * unit(c);
        }
        self.opacity += w;
        self.depth += w * t;
        w
    }

    /// Finishes the ray on the background; `far` is the depth of empty space.
    /// Colour and opacity are in `[0, 1]`; depth in `[0, far]` (a ray with
    /// no opacity has depth `far`).
    fn finish(&self, white_background: bool, far: f32) -> Pixel {
        let acc = unit(self.opacity);
        let rest = 1.0 - acc;
        let bg = if white_background { rest } else { 0.0 };
        let depth = self.depth + rest * far;
        Pixel {
            rgb: self.rgb.map(|c| unit(c + bg)),
            opacity: acc,
            depth: if depth >= 0.0 {
                depth.min(far)
            } else if depth < 0.0 {
                0.0
            } else {
                far
            },
        }
    }
}

/// `x` clamped to `[0, 1]`, NaN read as 0.
#[inline(always)]
fn unit(x: f32) -> f32 {
    if x >= 0.0 {
        x.min(1.0)
    } else {
        0.0
    }
}

/// Front-to-back accumulator of the fixed-point path (integer only).
#[derive(Clone, Copy, Debug)]
pub struct CompositorFixed {
    /// Transmittance before the next sample, Q30.
    pub transmittance: u32,
    rgb: [u64; 3],
    opacity: u64,
    depth: i64,
}

impl Default for CompositorFixed {
    fn default() -> Self {
        Self { transmittance: T_ONE, rgb: [0; 3], opacity: 0, depth: 0 }
    }
}

/// `δ` marking the last, infinite interval in the fixed path.
pub const DELTA_INF_Q16: i32 = i32::MAX;

/// `exp(−σδ)` in Q30 for σ in Q10 (ReLU applied) and δ in Q16.
#[inline(always)]
pub fn survival_fixed(sigma_q10: i32, delta_q16: i32) -> u32 {
    if sigma_q10 <= 0 || delta_q16 <= 0 {
        return T_ONE;
    }
    if delta_q16 == DELTA_INF_Q16 {
        return 0;
    }
    // σ·δ exactly, in Q26 (Q10 · Q16); < 2^31 · 2^31 fits i64.
    exp_neg_q26_q30(sigma_q10 as i64 * delta_q16 as i64)
}

impl Compositor<i32, i32, i32, [u16; 3]> for CompositorFixed {
    type W = u32;
    type Pixel = PixelFixed;
    type Factor = u32;

    #[inline(always)]
    fn transmittance(&self) -> u32 {
        self.transmittance
    }

    /// `exp(−σδ)` in Q30 ([`survival_fixed`]): σ in Q10, δ in Q16
    /// ([`DELTA_INF_Q16`] for the last interval).
    #[inline(always)]
    fn factor(sigma_q10: i32, delta_q16: i32) -> u32 {
        survival_fixed(sigma_q10, delta_q16)
    }

    /// Adds one sample that lets `survival` through (Q30, `0..=T_ONE`, as
    /// [`survival_fixed`] gives it): colour in Q15, `t` in Q16. Returns the
    /// weight in Q30.
    #[inline]
    fn add_factor(&mut self, survival: u32, rgb: [u16; 3], t_q16: i32) -> u32 {
        let e = survival as u64;
        let t = self.transmittance as u64;
        let alpha = T_ONE as u64 - e;
        let half = 1u64 << (T_FRAC - 1);
        let w = (t * alpha + half) >> T_FRAC;
        self.transmittance = ((t * e + half) >> T_FRAC) as u32;
        for (acc, c) in self.rgb.iter_mut().zip(rgb) {
            *acc += w * c as u64;
        }
        self.opacity += w;
        self.depth += w as i64 * t_q16 as i64;
        w as u32
    }

    /// Finishes the ray on the background; `far_q16` is the empty-ray depth.
    fn finish(&self, white_background: bool, far_q16: i32) -> PixelFixed {
        let acc = self.opacity.min(T_ONE as u64);
        let rest = T_ONE as u64 - acc;
        let half = 1u64 << (T_FRAC - 1);
        let bg = if white_background { rest * COLOR_ONE as u64 } else { 0 };
        let rgb = self.rgb.map(|c| (((c + bg + half) >> T_FRAC).min(COLOR_ONE as u64)) as u16);
        let depth = (self.depth + rest as i64 * far_q16 as i64 + half as i64) >> T_FRAC;
        PixelFixed { rgb, opacity: ((acc + (1 << 14)) >> 15) as u16, depth: depth.clamp(0, far_q16 as i64) as i32 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worked_example_two_half_alphas() {
        let d = core::f32::consts::LN_2; // σδ = ln 2 → α = ½
        let mut c = CompositorF32::default();
        assert!((c.add(1.0, d, [1.0, 0.0, 0.0], 1.0) - 0.5).abs() < 1e-6);
        assert!((c.add(1.0, d, [0.0, 1.0, 0.0], 2.0) - 0.25).abs() < 1e-6);
        let p = c.finish(false, 4.0);
        assert!((p.opacity - 0.75).abs() < 1e-6);
        assert!((p.depth - (0.5 + 0.5 + 0.25 * 4.0)).abs() < 1e-5);
        let mut q = CompositorFixed::default();
        let dq = (d * 65536.0) as i32;
        q.add(1 << 10, dq, [32768, 0, 0], 1 << 16);
        q.add(1 << 10, dq, [0, 32768, 0], 2 << 16);
        let pq = q.finish(false, 4 << 16).to_pixel();
        assert!((pq.opacity - 0.75).abs() < 1e-4 && (pq.rgb[0] - 0.5).abs() < 1e-4);
        assert!((pq.depth - p.depth).abs() < 1e-3);
    }

    #[test]
    fn empty_ray_shows_background_at_far() {
        let p = CompositorF32::default().finish(true, 6.0);
        assert_eq!(p, Pixel { rgb: [1.0; 3], opacity: 0.0, depth: 6.0 });
        let q = CompositorFixed::default().finish(true, 6 << 16);
        assert_eq!(q, PixelFixed { rgb: [32768; 3], opacity: 0, depth: 6 << 16 });
    }

    #[test]
    fn last_interval_is_opaque() {
        let mut c = CompositorF32::default();
        assert_eq!(c.add(0.5, f32::INFINITY, [0.2; 3], 3.0), 1.0);
        let mut q = CompositorFixed::default();
        assert_eq!(q.add(1, DELTA_INF_Q16, [100; 3], 3 << 16), T_ONE);
    }
}
