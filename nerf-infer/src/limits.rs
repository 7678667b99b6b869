//! Capacity limits and format constants: the bottom of the crate, used by
//! the format, the error type and every stage that sizes a buffer.

/// The four bytes every model starts with.
pub const MAGIC: [u8; 4] = *b"NERF";
/// The eight bytes a training checkpoint starts with (`nerf_train`'s,
/// framed as a model is); the model reader names such a file.
pub const CHECKPOINT_MAGIC: [u8; 8] = *b"NERFCKPT";
/// The newest format version this build reads and writes (it reads 1 to 10 too).
pub const FORMAT_VERSION: u16 = 11;
/// The version of models without a proposal grid.
pub const FORMAT_VERSION_NO_PROPOSAL: u16 = 10;
/// The version of models without a pixel footprint.
pub const FORMAT_VERSION_NO_FOOTPRINT: u16 = 9;
/// The version of models without a fitted orbit.
pub const FORMAT_VERSION_NO_ORBIT: u16 = 8;
/// The version of models without a 16-bit density head.
pub const FORMAT_VERSION_NO_DENSITY16: u16 = 7;
/// The version of models without a narrow feature table or a 16-bit density head.
pub const FORMAT_VERSION_NO_NARROW: u16 = 6;
/// The version of unbounded models without 16-bit parts.
pub const FORMAT_VERSION_NO_PRECISE: u16 = 5;
/// The version of models with a capture record but no unbounded space.
pub const FORMAT_VERSION_NO_UNBOUNDED: u16 = 4;
/// The version of models with a feature grid but no capture record.
pub const FORMAT_VERSION_NO_CAPTURE: u16 = 3;
/// The version of models with an occupancy grid or pruned layers but no
/// feature grid.
pub const FORMAT_VERSION_NO_FEATURES: u16 = 2;
/// The version of models without an occupancy grid.
pub const FORMAT_VERSION_NO_GRID: u16 = 1;
/// Length of the fixed header before the postcard payload, in bytes.
pub const HEADER_LEN: usize = 14;
/// Most layers a network may have (trunk + heads).
pub const MAX_LAYERS: usize = 24;
/// Widest layer (inputs or outputs) the kernel's scratch buffers hold.
pub const MAX_WIDTH: usize = 256;
/// Longest layer input: `MAX_WIDTH` plus the largest encoding (16 freqs +
/// raw + the feature grid's values).
pub const MAX_INPUT: usize = MAX_WIDTH + 3 + 6 * MAX_FREQS + MAX_FEATURES;
/// Highest number of encoding frequencies `L` (per coordinate).
pub const MAX_FREQS: usize = 16;
/// Most coarse samples per ray of a model with a fine network.
pub const MAX_COARSE: usize = 256;
/// Most fine samples per ray (in addition to the coarse ones).
pub const MAX_FINE: usize = 256;
/// Most samples per ray of a model without a fine network (one pass): the
/// scratch's sample buffer, which a two-pass render splits into the
/// coarse, fine and merged samples, holds this many.
pub const MAX_MARCH: usize = 2 * (MAX_COARSE + MAX_FINE);

/// Most coarse samples per ray for a model with `fine` importance samples
/// per ray: [`MAX_MARCH`] without a fine pass, [`MAX_COARSE`] with one.
pub const fn max_coarse(fine: usize) -> usize {
    if fine == 0 {
        MAX_MARCH
    } else {
        MAX_COARSE
    }
}

// The learned feature grid ([`crate::features`]).

/// Most levels a grid may have.
pub const MAX_LEVELS: usize = 16;
/// Most values the grid adds to the trunk's input (`levels × width`).
pub const MAX_FEATURES: usize = 32;
/// Largest table per level: `2^MAX_LOG2_TABLE` entries.
pub const MAX_LOG2_TABLE: u8 = 22;
/// Finest lattice, cells per axis.
pub const MAX_RES: u16 = 4096;

/// Points of a pixel footprint, evenly spread on its circle
/// ([`crate::format::Footprint`], [`crate::camera::Ray::with_footprint`]).
pub const FOOTPRINT_POINTS: usize = 3;
