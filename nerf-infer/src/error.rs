//! The crate's error type: every failure of loading or rendering is one of
//! these variants; nothing in this crate panics on bad input.

use core::fmt;

/// Everything that can go wrong when loading a model or setting up a render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// The blob is shorter than the fixed header or than its declared payload.
    Truncated,
    /// The first four bytes are not `b"NERF"`.
    BadMagic,
    /// The format version is not one this build reads (the found version).
    UnsupportedVersion(u16),
    /// The payload checksum (CRC-32) does not match.
    ChecksumMismatch,
    /// The payload is not a valid postcard encoding of the model.
    Decode,
    /// Bytes follow the payload.
    TrailingBytes,
    /// A scene field is invalid (bounds, near/far not finite or out of order).
    InvalidScene(&'static str),
    /// Encoding parameters out of range (frequencies > 16, ...).
    InvalidEncoding(&'static str),
    /// Topology out of range or inconsistent with the layers present.
    InvalidTopology(&'static str),
    /// A layer's dimensions do not chain with its neighbours (layer index).
    LayerShape(u8),
    /// A tensor's byte length does not match its shape (layer index).
    TensorLength(u8),
    /// A scale or requantisation constant is not finite or out of range (layer index).
    InvalidScale(u8),
    /// A layer uses a numeric scheme other than the network's (layer index).
    MixedScheme(u8),
    /// The model exceeds a compile-time capacity of this build (which one).
    Capacity(&'static str),
    /// Sample counts are zero or above the kernel's capacity.
    InvalidSamples,
    /// The renderer asked for does not render the model's numeric scheme
    /// (the model's scheme): `RendererF32` renders f32 models,
    /// `RendererFixed` int16 and int8 ones, [`crate::AnyRenderer`] any.
    WrongNumericPath(crate::Scheme),
    /// A camera parameter is not finite, or the pose is not a rigid transform.
    InvalidCamera,
    /// The tile lies outside the image, or the output buffer is too small.
    InvalidTile,
    /// The output buffer is too small for the encoded model.
    BufferTooSmall,
    /// The blob is a training checkpoint (`NERFCKPT`), not a model.
    Checkpoint,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Truncated => write!(f, "model data is truncated"),
            Error::BadMagic => write!(f, "not a NeRF model (bad magic)"),
            Error::UnsupportedVersion(v) => write!(
                f,
                "model format version {v} is not supported (this build reads versions {} to {})",
                crate::limits::FORMAT_VERSION_NO_GRID,
                crate::limits::FORMAT_VERSION
            ),
            Error::ChecksumMismatch => write!(f, "model checksum mismatch (corrupted file)"),
            Error::Decode => write!(f, "model payload cannot be decoded"),
            Error::TrailingBytes => write!(f, "unexpected bytes after the model payload"),
            Error::InvalidScene(w) => write!(f, "invalid scene: {w}"),
            Error::InvalidEncoding(w) => write!(f, "invalid encoding: {w}"),
            Error::InvalidTopology(w) => write!(f, "invalid topology: {w}"),
            Error::LayerShape(i) => write!(f, "layer {i}: dimensions do not match the topology"),
            Error::TensorLength(i) => {
                write!(f, "layer {i}: tensor length does not match its shape")
            }
            Error::InvalidScale(i) => write!(f, "layer {i}: scale or requantisation constant out of range"),
            Error::MixedScheme(i) => {
                write!(f, "layer {i}: numeric scheme differs from the network's")
            }
            Error::Capacity(w) => write!(f, "model exceeds this build's capacity: {w}"),
            Error::InvalidSamples => {
                write!(
                    f,
                    "sample counts are zero or exceed the kernel's capacity (2..=1024 coarse samples in one pass, \
                     2..=256 coarse and 0..=256 fine in two)"
                )
            }
            Error::WrongNumericPath(s) => {
                let needs = if *s == crate::Scheme::F32 { "RendererF32" } else { "RendererFixed" };
                write!(f, "a {s:?} model needs {needs} (or AnyRenderer, which takes any model)")
            }
            Error::InvalidCamera => write!(f, "camera parameters are not finite or the pose is not rigid"),
            Error::InvalidTile => write!(f, "tile outside the image or output buffer too small"),
            Error::BufferTooSmall => write!(f, "output buffer too small"),
            Error::Checkpoint => write!(
                f,
                "a training checkpoint, not a model: give the model.nerf of the same run folder (nerf train --resume \
                 continues the run)"
            ),
        }
    }
}

/// With or without `std`: `?` turns it into a `Box<dyn std::error::Error>`.
impl core::error::Error for Error {}

/// Result alias for this crate.
pub type Result<T> = core::result::Result<T, Error>;
