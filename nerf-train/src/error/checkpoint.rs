//! Why a checkpoint cannot be written or resumed ([`CheckpointError`]).

/// Why a training checkpoint cannot be written or resumed
/// ([`crate::train::Trainer::from_bytes`]).
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// A file without the checkpoint's header.
    #[error("not a checkpoint (no NERFCKPT header)")]
    NotACheckpoint,
    /// A format version this build does not read.
    #[error("checkpoint version {found}, this build reads versions {min} to {max} (written by another build)")]
    Version {
        /// The file's version.
        found: u16,
        /// The earliest version this build reads.
        min: u16,
        /// The latest version this build reads.
        max: u16,
    },
    /// A length or checksum that does not match: the frame's error.
    #[error("truncated or damaged (its length or checksum does not match)")]
    Damaged(#[source] nerf_infer::Error),
    /// A state the frame cannot hold (4 GiB or more): the frame's error.
    #[error("{0}")]
    Frame(#[source] nerf_infer::Error),
    /// The configuration cannot be written as JSON.
    #[error("cannot encode: {0}")]
    EncodeConfig(#[source] serde_json::Error),
    /// A section of the state cannot be encoded.
    #[error("cannot encode its {name}: {source}")]
    EncodeSection {
        /// The section.
        name: String,
        /// Postcard's reason.
        #[source]
        source: postcard::Error,
    },
    /// The list of sections cannot be encoded.
    #[error("cannot encode: {0}")]
    Encode(#[source] postcard::Error),
    /// The payload (the list of sections, or a version 18 state) cannot be decoded.
    #[error("cannot decode: {0}")]
    Decode(#[source] postcard::Error),
    /// A section of the state cannot be decoded.
    #[error("its {name} cannot be decoded: {source}")]
    DecodeSection {
        /// The section.
        name: String,
        /// Postcard's reason.
        #[source]
        source: postcard::Error,
    },
    /// The configuration's JSON cannot be read as this build's configuration.
    #[error("its cfg cannot be decoded: {0}")]
    DecodeConfig(#[source] serde_json::Error),
    /// The value an absent section is given cannot be decoded.
    #[error("its {name} cannot be decoded: {source}")]
    AbsentSection {
        /// The section.
        name: String,
        /// serde_json's reason.
        #[source]
        source: serde_json::Error,
    },
    /// The value an absent configuration field is given cannot be decoded.
    #[error("{name}: {source}")]
    AbsentField {
        /// The field, `cfg.SECTION.FIELD`.
        name: String,
        /// serde_json's reason.
        #[source]
        source: serde_json::Error,
    },
    /// A field an earlier build did not write that no value stands in for.
    #[error(
        "it has no {name} (written by an earlier build, before this build's {name} existed, and no value of it \
         means what that build did): start the run over with --force"
    )]
    Missing {
        /// The field: a section, or `cfg.SECTION.FIELD`.
        name: String,
    },
    /// A field this build does not know (a newer build's).
    #[error("it holds {name}, which this build does not know (written by a newer build)")]
    Unknown {
        /// The field: a section, or `cfg.SECTION.FIELD`.
        name: String,
    },
    /// Parameters, grids or configuration that do not fit together.
    #[error("its state is inconsistent (parameters, grids or configuration that do not fit together)")]
    Inconsistent {
        /// The part found not to fit (`grid`, `proposal`, `appearance`,
        /// `poses`, `cfg`, `pixel`, `params`, `adam`, `ema`); the
        /// message does not name it.
        part: &'static str,
    },
}

/// The error of plotters drawing on the plot's bitmap.
pub type DrawError = plotters::drawing::DrawingAreaErrorKind<
    <plotters::prelude::BitMapBackend<'static> as plotters::prelude::DrawingBackend>::ErrorType,
>;
