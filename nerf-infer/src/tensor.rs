//! Elements of the little-endian tensors a model blob holds.

/// Reads element `i` of a little-endian f32 tensor.
#[inline(always)]
pub fn read_f32(bytes: &[u8], i: usize) -> f32 {
    let b = &bytes[4 * i..4 * i + 4];
    f32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

/// Reads element `i` of a little-endian i32 tensor.
#[inline(always)]
pub fn read_i32(bytes: &[u8], i: usize) -> i32 {
    let b = &bytes[4 * i..4 * i + 4];
    i32::from_le_bytes([b[0], b[1], b[2], b[3]])
}

/// Reads element `i` of a little-endian i16 tensor.
#[inline(always)]
pub fn read_i16(bytes: &[u8], i: usize) -> i16 {
    i16::from_le_bytes([bytes[2 * i], bytes[2 * i + 1]])
}

/// A type's all-zero value as a constant: what the `const fn`
/// constructors of working memory ([`crate::Scratch::new`]) fill it with.
pub trait Zero: Sized {
    /// Zero (every element zero).
    const ZERO: Self;
}

macro_rules! zero {
    ($($t:ty = $z:expr),*) => {$(impl Zero for $t { const ZERO: Self = $z; })*};
}
zero!(f32 = 0.0, i16 = 0, u16 = 0, i32 = 0, u32 = 0, i64 = 0, u64 = 0);

impl<T: Zero + Copy, const N: usize> Zero for [T; N] {
    const ZERO: Self = [T::ZERO; N];
}
