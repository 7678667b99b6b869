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
