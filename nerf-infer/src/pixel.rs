//! Rendered pixels and their conversions to what displays and image files
//! take: 8 bits per channel (RGB888) and 5-6-5 bits (RGB565).
//!
//! Colours are encoded as the training photos store them (sRGB-encoded
//! values in `[0, 1]`, not linear light), so a conversion is a rounding,
//! with no transfer function. Every conversion saturates: an f32 value is
//! clamped to `[0, 1]` (NaN gives 0), a Q15 value above 32768 counts as
//! 32768. The integer conversions of [`PixelFixed`] give the same values as
//! those of the [`Pixel`] it converts to, with no float operation.

/// A rendered pixel from the f32 path.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Pixel {
    /// RGB in `[0, 1]`, sRGB-encoded as the training photos are,
    /// composited on the scene's background.
    pub rgb: [f32; 3],
    /// Accumulated opacity `Σ wᵢ` in `[0, 1]`.
    pub opacity: f32,
    /// Expected ray parameter `t` in `[near, far]` (empty rays: `far`),
    /// world units.
    pub depth: f32,
}

/// A rendered pixel from the fixed-point path.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelFixed {
    /// RGB in Q15, `[0, 32768]` (32768 = 1.0), sRGB-encoded as
    /// [`Pixel::rgb`]. 1.0 does not fit 15 bits: shift with care, or use
    /// [`PixelFixed::to_rgb888`] / [`PixelFixed::to_rgb565`].
    pub rgb: [u16; 3],
    /// Accumulated opacity in Q15, `[0, 32768]`.
    pub opacity: u16,
    /// Expected ray parameter `t` in Q16 world units, in `[near, far]`.
    pub depth: i32,
}

/// A colour value in `[0, 1]` as an 8-bit value: clamped, then rounded
/// half up (`⌊255·v + ½⌋`); NaN gives 0. What image files and the browser
/// viewer store.
#[inline]
pub fn to_u8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// `v` in `[0, 1]` (clamped; NaN 0) on `max + 1` levels, rounded half up.
#[inline]
fn to_levels(v: f32, max: u16) -> u16 {
    (v.clamp(0.0, 1.0) * max as f32 + 0.5) as u16
}

/// A Q15 value (saturated at 32768) on `max + 1` levels, rounded half up:
/// `⌊(c·max + 2¹⁴) / 2¹⁵⌋`.
#[inline]
fn q15_to_levels(c: u16, max: u16) -> u16 {
    ((c.min(32768) as u32 * max as u32 + (1 << 14)) >> 15) as u16
}

/// RGB565 from three channels on 32, 64 and 32 levels: red in the top 5
/// bits, blue in the low 5.
#[inline]
fn pack565(r: u16, g: u16, b: u16) -> u16 {
    r << 11 | g << 5 | b
}

impl Pixel {
    /// The colour as 8-bit RGB ([`to_u8`] per channel).
    #[inline]
    pub fn to_rgb888(&self) -> [u8; 3] {
        self.rgb.map(to_u8)
    }

    /// The colour as RGB565 (red in bits 15–11, green 10–5, blue 4–0), each
    /// channel rounded half up to its 5 or 6 bits.
    #[inline]
    pub fn to_rgb565(&self) -> u16 {
        let [r, g, b] = self.rgb;
        pack565(to_levels(r, 31), to_levels(g, 63), to_levels(b, 31))
    }
}

impl PixelFixed {
    /// Converts to the f32 representation (exact: every field fits f32).
    pub fn to_pixel(&self) -> Pixel {
        Pixel {
            rgb: self.rgb.map(|c| c as f32 / 32768.0),
            opacity: self.opacity as f32 / 32768.0,
            depth: self.depth as f32 / 65536.0,
        }
    }

    /// The colour as 8-bit RGB, integers only: the values
    /// [`Pixel::to_rgb888`] gives for [`PixelFixed::to_pixel`].
    #[inline]
    pub fn to_rgb888(&self) -> [u8; 3] {
        self.rgb.map(|c| q15_to_levels(c, 255) as u8)
    }

    /// The colour as RGB565, integers only: the value [`Pixel::to_rgb565`]
    /// gives for [`PixelFixed::to_pixel`].
    #[inline]
    pub fn to_rgb565(&self) -> u16 {
        let [r, g, b] = self.rgb;
        pack565(q15_to_levels(r, 31), q15_to_levels(g, 63), q15_to_levels(b, 31))
    }
}

impl From<PixelFixed> for Pixel {
    /// [`PixelFixed::to_pixel`].
    fn from(p: PixelFixed) -> Pixel {
        p.to_pixel()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every Q15 value (and past 1.0) converts as its f32 value does, and
    /// the extremes saturate.
    #[test]
    fn integer_conversions_equal_the_f32_ones_and_saturate() {
        for c in 0..=u16::MAX {
            let p = PixelFixed { rgb: [c, 32768 - c.min(32768), c / 2], opacity: 0, depth: 0 };
            let clamped = PixelFixed { rgb: p.rgb.map(|v| v.min(32768)), ..p };
            assert_eq!(p.to_rgb888(), clamped.to_pixel().to_rgb888(), "c {c}");
            assert_eq!(p.to_rgb565(), clamped.to_pixel().to_rgb565(), "c {c}");
        }
        let white = PixelFixed { rgb: [32768; 3], ..Default::default() };
        assert_eq!(white.to_rgb888(), [255; 3]);
        assert_eq!(white.to_rgb565(), 0xffff);
        // a value just under 1.0 rounds up to full scale, half a step under it does not
        assert_eq!(PixelFixed { rgb: [32767, 0, 0], ..white }.to_rgb565(), 0xf800);
        assert_eq!(Pixel { rgb: [30.5 / 31.0 - 1e-4, 0.0, 0.0], ..Default::default() }.to_rgb565(), 30 << 11);
        let odd = Pixel { rgb: [f32::NAN, -3.0, 7.0], ..Default::default() };
        assert_eq!((odd.to_rgb888(), odd.to_rgb565()), ([0, 0, 255], 0x001f));
        assert_eq!(Pixel::from(white), white.to_pixel());
    }
}
