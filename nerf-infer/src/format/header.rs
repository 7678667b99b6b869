//! The framing shared by model files and training checkpoints (magic,
//! version, payload length, CRC-32), the model's 14-byte header on it, and
//! the reading of older versions' payloads as the newest.

use crate::error::{Error, Result};
use crate::limits::{CHECKPOINT_MAGIC, FORMAT_VERSION, FORMAT_VERSION_NO_GRID, MAGIC};

/// Bytes of a frame after its magic: the version (u16 LE), the payload's
/// length (u32 LE) and the payload's CRC-32 (u32 LE).
pub const FRAME_FIELDS_LEN: usize = 10;

/// Checks magic, version, length and checksum; returns the version and the payload.
pub(super) fn check_header(bytes: &[u8]) -> Result<(u16, &[u8])> {
    // in two halves: one 8-byte comparison here grows the decode's stack (scripts/check/stack_table.sh)
    if bytes.len() >= 8 && bytes[0..4] == CHECKPOINT_MAGIC[..4] && bytes[4..8] == CHECKPOINT_MAGIC[4..] {
        return Err(Error::Checkpoint);
    }
    unframe(bytes, &MAGIC, FORMAT_VERSION_NO_GRID, FORMAT_VERSION)
}

/// Splits a framed container: `magic`, then the version (u16 LE), the
/// payload's length (u32 LE), its CRC-32 (u32 LE, [`crc32`]) and the
/// payload. Checked in that order: [`Error::Truncated`] (shorter than the
/// magic, the header or the stated length), [`Error::BadMagic`],
/// [`Error::UnsupportedVersion`] (outside `oldest..=newest`),
/// [`Error::TrailingBytes`], [`Error::ChecksumMismatch`]. Returns the
/// version and the payload. Model files use it with [`MAGIC`]; the
/// trainer's checkpoints with their own magic. Always inlined: out of
/// line it grows the decode's stack (`scripts/check/stack_table.sh --check`).
#[inline(always)]
pub fn unframe<'a>(bytes: &'a [u8], magic: &[u8], oldest: u16, newest: u16) -> Result<(u16, &'a [u8])> {
    let m = magic.len();
    if bytes.len() < m {
        return Err(Error::Truncated);
    }
    if bytes[..m] != *magic {
        return Err(Error::BadMagic);
    }
    if bytes.len() < m + FRAME_FIELDS_LEN {
        return Err(Error::Truncated);
    }
    let version = u16::from_le_bytes([bytes[m], bytes[m + 1]]);
    if !(oldest..=newest).contains(&version) {
        return Err(Error::UnsupportedVersion(version));
    }
    let len = u32::from_le_bytes([bytes[m + 2], bytes[m + 3], bytes[m + 4], bytes[m + 5]]) as usize;
    let crc = u32::from_le_bytes([bytes[m + 6], bytes[m + 7], bytes[m + 8], bytes[m + 9]]);
    let rest = &bytes[m + FRAME_FIELDS_LEN..];
    if rest.len() < len {
        return Err(Error::Truncated);
    }
    if rest.len() > len {
        return Err(Error::TrailingBytes);
    }
    if crc32(rest) != crc {
        return Err(Error::ChecksumMismatch);
    }
    Ok((version, rest))
}

/// Frames `payload` as [`unframe`] reads it: `magic`, `version`, the
/// length and the CRC-32, then the payload. Fails with
/// [`Error::Capacity`] for a payload of 4 GiB or more.
#[cfg(feature = "alloc")]
pub fn frame(magic: &[u8], version: u16, payload: &[u8]) -> Result<alloc::vec::Vec<u8>> {
    let len = u32::try_from(payload.len()).map_err(|_| Error::Capacity("a payload of 4 GiB or more"))?;
    let mut out = alloc::vec::Vec::with_capacity(magic.len() + FRAME_FIELDS_LEN + payload.len());
    out.extend_from_slice(magic);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(&crc32(payload).to_le_bytes());
    out.extend_from_slice(payload);
    Ok(out)
}

static CRC_TABLE: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
            k += 1;
        }
        t[i] = c;
        i += 1;
    }
    t
};

/// CRC-32 (IEEE 802.3, reflected, as zlib's `crc32`).
pub fn crc32(data: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in data {
        c = CRC_TABLE[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
    }
    !c
}

/// An older version's payload read as the newest: the payload, then one
/// `0` byte (postcard's `None`) for each field appended since. Tensors are
/// borrowed from the payload; the padding only ever holds `None` tags.
pub(super) struct Padded<'a> {
    pub(super) rest: &'a [u8],
    pub(super) absent: usize,
}

impl<'a> postcard::de_flavors::Flavor<'a> for Padded<'a> {
    type Remainder = ();
    type Source = &'a [u8];

    fn pop(&mut self) -> postcard::Result<u8> {
        if let Some((&b, rest)) = self.rest.split_first() {
            self.rest = rest;
            Ok(b)
        } else if self.absent > 0 {
            self.absent -= 1;
            Ok(0)
        } else {
            Err(postcard::Error::DeserializeUnexpectedEnd)
        }
    }

    fn try_take_n(&mut self, ct: usize) -> postcard::Result<&'a [u8]> {
        if ct > self.rest.len() {
            return Err(postcard::Error::DeserializeUnexpectedEnd);
        }
        let (taken, rest) = self.rest.split_at(ct);
        self.rest = rest;
        Ok(taken)
    }

    /// The payload must be exactly its version's encoding: no bytes left,
    /// every appended field read as absent.
    fn finalize(self) -> postcard::Result<()> {
        if self.rest.is_empty() && self.absent == 0 {
            Ok(())
        } else {
            Err(postcard::Error::DeserializeBadEncoding)
        }
    }
}

const _: () = assert!(crate::limits::HEADER_LEN == MAGIC.len() + FRAME_FIELDS_LEN);
