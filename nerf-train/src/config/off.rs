//! Serde for a count whose 0 turns a part of the run off, held as
//! `Option<NonZeroU8>` or `Option<NonZeroU16>` (`#[serde(with = "off")]`):
//! written as the plain integer, 0 for `None`. JSON reads an integer or
//! `null` (both 0 and `null`: `None`); a binary format (postcard) reads the
//! integer alone, so the bytes are those of a plain `u8` or `u16` field.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::num::{NonZeroU16, NonZeroU8};

/// A nonzero integer and the plain integer it is written as.
pub trait NonZeroInt: Copy + Sized {
    /// The plain integer.
    type Int: Serialize + for<'de> Deserialize<'de> + Default;
    /// `Some` for a nonzero `n`, `None` for 0.
    fn from_int(n: Self::Int) -> Option<Self>;
    /// The integer.
    fn to_int(self) -> Self::Int;
}

macro_rules! non_zero_int {
    ($($nz:ty => $int:ty),*) => {$(
        impl NonZeroInt for $nz {
            type Int = $int;
            fn from_int(n: $int) -> Option<Self> {
                Self::new(n)
            }
            fn to_int(self) -> $int {
                self.get()
            }
        }
    )*};
}

non_zero_int!(NonZeroU8 => u8, NonZeroU16 => u16);

/// Writes `n`'s integer, 0 for `None`.
pub fn serialize<N: NonZeroInt, S: Serializer>(n: &Option<N>, s: S) -> Result<S::Ok, S::Error> {
    n.map_or_else(N::Int::default, N::to_int).serialize(s)
}

/// Reads an integer (0: `None`), in JSON also `null` (`None`).
pub fn deserialize<'de, N: NonZeroInt, D: Deserializer<'de>>(d: D) -> Result<Option<N>, D::Error> {
    if d.is_human_readable() {
        Ok(Option::<N::Int>::deserialize(d)?.and_then(N::from_int))
    } else {
        N::Int::deserialize(d).map(N::from_int)
    }
}
