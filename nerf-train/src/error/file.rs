//! Why a file a user names cannot be used ([`FileError`], [`ReadError`], a camera path's
//! [`CameraPathError`] and [`PathEntryError`]).

use super::*;

/// Why a file a user names cannot be used: the file and the cause.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    /// A file that cannot be read whole as what it is to be.
    #[error("{}: {what}: {reason}", path.display())]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// What it was to be (`camera path`, `checkpoint`).
        what: String,
        /// Why it cannot be read.
        #[source]
        reason: ReadError,
    },
    /// A camera path file that cannot be rendered.
    #[error("{}: {reason}", path.display())]
    CameraPath {
        /// The file.
        path: PathBuf,
        /// What is wrong in it.
        #[source]
        reason: CameraPathError,
    },
}

/// Why a file a user names cannot be read whole
/// ([`crate::util::userfile`]): the cause alone, without the file.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The system cannot read or open it.
    #[error("{action}: {source}")]
    Io {
        /// What could not be done (`cannot read`, `cannot open`).
        action: &'static str,
        /// What the system reported.
        #[source]
        source: std::io::Error,
    },
    /// A folder, not a file.
    #[error("cannot read: is a folder, not a file")]
    Folder,
    /// A FIFO, device or socket, which could block or never end.
    #[error("not a regular file (a FIFO, device or socket); give a file")]
    NotRegular,
    /// A file swapped for another kind between its check and its opening.
    #[error("not a regular file")]
    Swapped,
    /// A file larger than accepted.
    #[error("{size} bytes, more than the {max} accepted")]
    TooLarge {
        /// Its size, bytes.
        size: u64,
        /// The most accepted, bytes.
        max: u64,
    },
    /// A file grown past the most accepted while it was read.
    #[error("more than the {max} bytes accepted")]
    Grown {
        /// The most accepted, bytes.
        max: u64,
    },
    /// Contents that are not UTF-8 text.
    #[error("not UTF-8 text")]
    NotUtf8(#[source] std::str::Utf8Error),
}

/// What is wrong in a camera path file ([`crate::path::read_camera_path`]).
#[derive(Debug, thiserror::Error)]
pub enum CameraPathError {
    /// Text that is not JSON.
    #[error("malformed JSON: {0}")]
    Json(#[source] serde_json::Error),
    /// A `camera_type` other than `perspective`.
    #[error("camera_type {found} is not supported (perspective is)")]
    CameraType {
        /// The type the file names.
        found: String,
    },
    /// JSON that is not an object.
    #[error("expected a JSON object with a camera_path list or keyframes")]
    NotAnObject,
    /// A field that is not a number.
    #[error("{key} is not a number: {value}")]
    NotANumber {
        /// The field.
        key: &'static str,
        /// Its value.
        value: serde_json::Value,
    },
    /// A render size that is not positive.
    #[error("render_width {width} and render_height {height} must be positive")]
    RenderSize {
        /// `render_width`.
        width: f64,
        /// `render_height`.
        height: f64,
    },
    /// A field that is not a list.
    #[error("{key} is not a list")]
    NotAList {
        /// The field (`camera_path`, `keyframes`).
        key: &'static str,
    },
    /// Neither a `camera_path` list nor `keyframes`.
    #[error("neither a camera_path list nor keyframes")]
    NoCameras,
    /// Empty `camera_path` and `keyframes` lists.
    #[error("its camera_path and keyframes lists are empty")]
    Empty,
    /// More cameras than are rendered.
    #[error("{count} cameras listed (at most 100000 are rendered)")]
    TooMany {
        /// The cameras listed.
        count: usize,
    },
    /// A camera or keyframe of the file that is refused.
    #[error("{kind} {index}: {reason}")]
    Entry {
        /// `camera` or `keyframe`.
        kind: &'static str,
        /// Its index in its list.
        index: usize,
        /// What is wrong with it.
        #[source]
        reason: PathEntryError,
    },
    /// Keyframes without `fps`.
    #[error("keyframes without fps (frames per second)")]
    NoFps,
    /// Keyframes without `seconds`.
    #[error("keyframes without seconds (the video's length)")]
    NoSeconds,
    /// An `fps` or `seconds` that is not positive.
    #[error("fps {} and seconds {} must both be positive", number(*.fps), number(*.seconds))]
    Timing {
        /// `fps`.
        fps: f64,
        /// `seconds`.
        seconds: f64,
    },
    /// An `fps` and `seconds` that give too few or too many frames.
    #[error(
        "fps {} × seconds {} gives {} frames (1 to 100000 are rendered)",
        number(*.fps),
        number(*.seconds),
        number(*.frames)
    )]
    Frames {
        /// `fps`.
        fps: f64,
        /// `seconds`.
        seconds: f64,
        /// Their product, rounded.
        frames: f64,
    },
    /// A `smoothness_value` outside -1..=1.
    #[error("smoothness_value {} is out of range (-1 to 1)", number(*.value))]
    Smoothness {
        /// The value.
        value: f64,
    },
    /// An `is_cycle` that is not a boolean.
    #[error("is_cycle is not true or false: {value}")]
    Cycle {
        /// The value.
        value: serde_json::Value,
    },
    /// An interpolated frame that is not a rigid camera.
    #[error("frame {frame} between the keyframes is not a rigid camera")]
    NotRigid {
        /// The frame's index.
        frame: usize,
    },
}

/// What is wrong with one camera or keyframe of a camera path file.
#[derive(Debug, thiserror::Error)]
pub enum PathEntryError {
    /// A matrix missing or not a list of numbers.
    #[error("its matrix is missing or not a list of numbers")]
    NoMatrix,
    /// A matrix of another length than 16 or 12.
    #[error("its matrix has {count} numbers (16 or 12)")]
    MatrixLength {
        /// The numbers it has.
        count: usize,
    },
    /// A 4×4 matrix whose bottom row is not 0 0 0 1.
    #[error(
        "its matrix's bottom row is {}, not 0 0 0 1 (not a rigid transform)",
        .row.iter().map(|&x| number(x)).collect::<Vec<_>>().join(" ")
    )]
    BottomRow {
        /// The bottom row.
        row: [f64; 4],
    },
    /// A field that is not a number.
    #[error("{key} is not a number: {value}")]
    NotANumber {
        /// The field.
        key: &'static str,
        /// Its value.
        value: serde_json::Value,
    },
    /// No `fov`.
    #[error("fov is missing (the vertical field of view, degrees)")]
    NoFov,
    /// A `fov` outside 1..179 degrees.
    #[error("fov {}° is out of range (1 to 179 degrees, vertical)", number(*.fov))]
    Fov {
        /// The vertical field of view, degrees.
        fov: f64,
    },
    /// No `aspect`, and no render size to take it from.
    #[error("aspect is missing (width / height), and the file has no render_width and render_height")]
    NoAspect,
    /// An `aspect` outside 0.01..100.
    #[error("aspect {} is out of range (0.01 to 100, width / height)", number(*.aspect))]
    Aspect {
        /// Width / height.
        aspect: f64,
    },
    /// A camera that is not finite or whose rotation is not rigid.
    #[error("not finite, or the rotation is not rigid")]
    NotRigid,
}
