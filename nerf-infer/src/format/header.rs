//! The 14-byte header (magic, version, payload length, CRC-32) and the
//! reading of older versions' payloads as the newest.

use crate::error::{Error, Result};
use crate::limits::{FORMAT_VERSION, FORMAT_VERSION_NO_GRID, HEADER_LEN, MAGIC};

/// Checks magic, version, length and checksum; returns the version and the payload.
pub(super) fn check_header(bytes: &[u8]) -> Result<(u16, &[u8])> {
    if bytes.len() < 4 {
        return Err(Error::Truncated);
    }
    if bytes[0..4] != MAGIC {
        return Err(Error::BadMagic);
    }
    if bytes.get(4..8) == Some(b"CKPT") {
        return Err(Error::Checkpoint);
    }
    if bytes.len() < HEADER_LEN {
        return Err(Error::Truncated);
    }
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    if !(FORMAT_VERSION_NO_GRID..=FORMAT_VERSION).contains(&version) {
        return Err(Error::UnsupportedVersion(version));
    }
    let len = u32::from_le_bytes([bytes[6], bytes[7], bytes[8], bytes[9]]) as usize;
    let crc = u32::from_le_bytes([bytes[10], bytes[11], bytes[12], bytes[13]]);
    let rest = &bytes[HEADER_LEN..];
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
