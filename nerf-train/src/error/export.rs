//! Why a model cannot be exported as asked ([`ExportError`]).

/// Why a model cannot be exported, quantised or narrowed as asked.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// A quantisation to f32 (int16 and int8 are its targets).
    #[error("quantise to int16 or int8")]
    NotQuantised,
    /// Activations of a width the weights' scheme does not take.
    #[error("{act_bits}-bit activations need int8 weights")]
    ActivationBits {
        /// The activations' width, bits.
        act_bits: u8,
    },
    /// A layer whose calibrated activation range is not finite or not positive.
    #[error(
        "layer {layer}: activation range is not finite or not positive (scale {scale}): the model's calibration \
         saw non-finite activations; retrain or export at 32 bits"
    )]
    ActivationRange {
        /// The layer's index.
        layer: usize,
        /// The scale at fault.
        scale: f64,
    },
    /// A model to quantise that is quantised already.
    #[error("the model is already quantised; export from the f32 model")]
    AlreadyQuantised,
    /// A grid to coarsen on a model without an occupancy grid.
    #[error("the model has no occupancy grid")]
    NoGrid,
    /// A grid resolution that does not divide the model's.
    #[error("--grid-res {res} must divide the model's grid resolution {model}")]
    GridRes {
        /// The resolution asked for.
        res: u16,
        /// The model's grid resolution.
        model: usize,
    },
    /// Table indices of another width than 8 or 4 bits.
    #[error("{bits}-bit table indices: 8 or 4 (16 is the i16 table)")]
    TableBits {
        /// The width asked for, bits.
        bits: u8,
    },
    /// Narrow table indices asked for on an f32 model.
    #[error("{bits}-bit table indices need --bits 16 or 8 (an f32 model keeps an f32 table)")]
    TableOfF32 {
        /// The width asked for, bits.
        bits: u8,
    },
    /// A table to narrow on a model without a feature grid.
    #[error("the model has no feature grid")]
    NoFeatures,
    /// A feature table to narrow that is narrow already.
    #[error("the feature table is already narrow")]
    AlreadyNarrow,
}
