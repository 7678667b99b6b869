//! The crate's one error type, [`Error`]: its variant says which stage
//! failed and holds that stage's typed cause, whose message names what is
//! at fault (the file, the field, the camera) and, where there is one,
//! what to do. A stage's own functions may return the error that stage
//! wraps ([`DataError`], [`ParseError`], [`MeshError`], [`ConfigError`],
//! [`CameraError`], [`ExportError`], [`FileError`], [`CheckpointError`],
//! [`PlotError`], each converting into [`Error`] with `?`); the low-level
//! file writers (`atomic`, the COLMAP and `.npy` writers) return
//! `std::io::Result`; a caller names the file, in its stage's error or in
//! [`Error::Io`] ([`Error::io`], as the plot writer does). Where the cause
//! is another crate's error (an I/O error, serde_json's, postcard's,
//! plotters', `nerf-infer`'s), the typed error holds it as its source.

use crate::dataset::colmap_io::CameraModel;
use std::fmt;
use std::path::{Path, PathBuf};

/// Everything that can go wrong in `nerf-train`, by stage.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A dataset: a file or folder that cannot be loaded as one.
    #[error(transparent)]
    Data(#[from] DataError),
    /// A COLMAP model file.
    #[error(transparent)]
    Colmap(#[from] ParseError),
    /// A capture's cameras: a camera model or rays training cannot use.
    #[error(transparent)]
    Camera(#[from] CameraError),
    /// A training configuration: the field and the range it must be in.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A model that cannot be exported, quantised or narrowed as asked.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// A file a user names (a camera path, a model, a checkpoint): its
    /// size, type or content.
    #[error(transparent)]
    File(#[from] FileError),
    /// A training checkpoint that cannot be resumed: why.
    #[error("not a valid checkpoint: {0}")]
    Checkpoint(#[from] CheckpointError),
    /// A mesh that cannot be made.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A model the renderer refuses (to write, to read or to render).
    #[error("the model: {0}")]
    Model(#[from] nerf_infer::Error),
    /// A plot that cannot be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A file that cannot be read or written: its path and the system's
    /// reason.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system reported.
        #[source]
        source: std::io::Error,
    },
}

impl Error {
    /// For `map_err` on an I/O result about `path`: the error as
    /// [`Error::Io`], naming the file.
    pub fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
        move |source| Error::Io { path: path.to_path_buf(), source }
    }
}

/// For callers whose errors are messages (the `nerf` command): the message.
impl From<Error> for String {
    fn from(e: Error) -> String {
        e.to_string()
    }
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// A dataset loading error: the file and what is wrong with it.
#[derive(Debug, thiserror::Error)]
#[error("{}: {msg}", path.display())]
pub struct DataError {
    /// The file (or directory) at fault.
    pub path: PathBuf,
    /// What is wrong, one line.
    pub msg: String,
}

impl DataError {
    /// An error about `path`.
    pub fn new(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Self { path: path.as_ref().to_path_buf(), msg: msg.into() }
    }
}

/// A file that cannot be read as a COLMAP model: which file and why.
#[derive(Debug, Clone, PartialEq)]
pub struct ParseError {
    /// The file at fault.
    pub path: PathBuf,
    /// What is wrong, one line.
    pub msg: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.msg)
    }
}

impl std::error::Error for ParseError {}

impl From<ParseError> for DataError {
    fn from(e: ParseError) -> Self {
        DataError::new(e.path, e.msg)
    }
}

/// Why a mesh cannot be made.
#[derive(Debug)]
pub enum MeshError {
    /// The scene is forward-facing: its bounds are in NDC, not world units.
    Ndc,
    /// An option is out of range (the message says which).
    Option(String),
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshError::Ndc => write!(
                f,
                "the model is of a forward-facing scene (NDC space), which has no bounded volume to mesh; \
                 train with --scene object or --scene unbounded"
            ),
            MeshError::Option(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for MeshError {}

/// Why a training configuration is refused: the field at fault and the
/// range or rule it breaks, or what in a `--config` object is not a
/// configuration.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A field out of its range or against a rule (its message starts with the field).
    #[error("{field} {rule}")]
    Invalid {
        /// The field at fault, `section.field` (the first one the rule names).
        field: &'static str,
        /// What follows the field in the message: its value where shown,
        /// then the range or rule it breaks (`must be 1..=256`).
        rule: String,
    },
    /// A rule over several fields, stated whole (its message does not start with a field).
    #[error("{rule}")]
    Combination {
        /// The fields the rule ties together, `section.field`.
        fields: &'static [&'static str],
        /// The rule, as the message states it.
        rule: &'static str,
    },
    /// A configuration the proposal grid `nerf train` gives a scene cannot serve.
    #[error(
        "invalid configuration: {source} (the proposal grid this {kind} scene gets; set sampling.proposal_res 0 \
         with --config to train it with the occupancy grid instead)"
    )]
    ProposalGrid {
        /// The scene's kind (`forward-facing`, `unbounded`).
        kind: &'static str,
        /// The rule the configuration with the grid breaks.
        #[source]
        source: Box<ConfigError>,
    },
    /// A `--config` value that is not a JSON object.
    #[error("expected a JSON object of configuration sections or fields")]
    NotAnObject,
    /// A name that is neither a section nor a field's flat name.
    #[error(
        "unknown field `{name}`: expected a section ({}) or a field's flat name{}",
        crate::config::json::SECTIONS.join(", "),
        within_hint(.within)
    )]
    UnknownName {
        /// The name as given.
        name: String,
        /// The field of that name within a section, if there is one.
        within: Option<crate::config::json::FlatName>,
    },
    /// A section given as something other than an object of fields.
    #[error("`{section}` must be an object of fields")]
    NotASection {
        /// The section.
        section: String,
    },
    /// A section this build does not have.
    #[error("unknown section `{section}`")]
    UnknownSection {
        /// The section as given.
        section: String,
    },
    /// A field given both nested in its section and by its flat name.
    #[error("`{section}.{field}` is given twice, nested and flat")]
    Twice {
        /// The field's section.
        section: &'static str,
        /// The field's name in the section.
        field: String,
    },
    /// A field named at the place it has moved from.
    #[error(
        "`{from}` is `{to}` (`{{\"{}\": {{\"{}\": …}}}}`, or by its flat name `{flat}`)",
        section_and_field(.to).0,
        section_and_field(.to).1
    )]
    Moved {
        /// Where it was, `section.field`.
        from: String,
        /// Where it is, `section.field`.
        to: &'static str,
        /// Its flat name.
        flat: String,
    },
    /// A field's value of the wrong type: the field and serde_json's reason.
    #[error("`{field}`: {source}")]
    Value {
        /// The field, `section.field`.
        field: String,
        /// Why serde_json cannot read the value as the field's.
        #[source]
        source: serde_json::Error,
    },
    /// The configuration cannot be turned into JSON or read back from it.
    #[error("{0}")]
    Json(#[source] serde_json::Error),
}

impl ConfigError {
    /// A field out of its range or against a rule: `field` and what
    /// follows it in the message.
    pub fn invalid(field: &'static str, rule: impl Into<String>) -> Self {
        ConfigError::Invalid { field, rule: rule.into() }
    }
}

/// The hint of [`ConfigError::UnknownName`]: how to name the field of that
/// name within a section.
fn within_hint(within: &Option<crate::config::json::FlatName>) -> String {
    within.as_ref().map_or(String::new(), |crate::config::json::FlatName { flat, section, field }| {
        format!(" (the field `{field}` of `{section}` is `{{\"{section}\": {{\"{field}\": …}}}}` or `{flat}`)")
    })
}

/// `section.field` as its section and field (the whole as the section
/// without a dot).
fn section_and_field(path: &str) -> (&str, &str) {
    path.split_once('.').unwrap_or((path, ""))
}

/// Why a capture's cameras cannot be trained on or rendered from.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// A COLMAP camera with another number of parameters than its model has.
    #[error("{} needs {} parameters, found {found}", .model.name(), .model.num_params())]
    ParameterCount {
        /// The camera's model.
        model: CameraModel,
        /// How many parameters the camera has.
        found: usize,
    },
    /// A FOV camera whose field of view is not within (−π, π).
    #[error("FOV camera's field of view ω = {omega} is not within (−π, π)")]
    FieldOfView {
        /// The field of view ω, radians.
        omega: f64,
    },
    /// A COLMAP camera model that has no lens here.
    #[error(
        "camera model {} is not supported (SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, \
         FULL_OPENCV, OPENCV_FISHEYE, SIMPLE_RADIAL_FISHEYE, RADIAL_FISHEYE, SIMPLE_FISHEYE, FISHEYE, \
         THIN_PRISM_FISHEYE, FOV are; undistort the images with colmap image_undistorter)",
        .model.name()
    )]
    Unsupported {
        /// The camera's model.
        model: CameraModel,
    },
    /// Focal lengths, principal point or lens not finite, or focal lengths not positive.
    #[error("non-finite or non-positive camera parameters")]
    NotFinite,
    /// A principal point outside its photo.
    #[error("principal point ({}, {}) lies outside the {width}x{height} image", .centre[0], .centre[1])]
    CentreOutside {
        /// The principal point, pixels.
        centre: [f64; 2],
        /// The photo's width, pixels.
        width: u64,
        /// The photo's height, pixels.
        height: u64,
    },
    /// Masks that leave fewer than 1 % of the pixels to train on.
    #[error(
        "the photos' masks leave {kept} of the {total} pixels to train on (a pixel whose mask is 0 is left \
         out): check that the masks are the photos' own and not inverted"
    )]
    MasksLeave {
        /// The pixels the masks keep.
        kept: usize,
        /// All the photos' pixels.
        total: usize,
    },
    /// Fewer than 1 % of the training rays meet the scene box within near..far.
    #[error(
        "only {:.2} % of the training rays meet the scene box {:?}..{:?} within near {} .. far {}: \
         the cameras look away from it or the bounds are wrong; check the poses, the aabb/near/far of the \
         transforms file, or try --scene unbounded",
        100.0 * .share,
        .bounds_min,
        .bounds_max,
        .near,
        .far
    )]
    RaysMiss {
        /// The share of the training rays that meet it, in [0, 1].
        share: f64,
        /// The scene box's lower corner.
        bounds_min: [f32; 3],
        /// The scene box's upper corner.
        bounds_max: [f32; 3],
        /// The near distance.
        near: f32,
        /// The far distance.
        far: f32,
    },
    /// A smoothed trajectory asked for without cameras, frames or a width.
    #[error("a smoothed trajectory needs cameras ({cameras} given), frames ({frames}) and a width ({width})")]
    EmptyTrajectory {
        /// The cameras given.
        cameras: usize,
        /// The frames asked for.
        frames: usize,
        /// The width asked for, pixels.
        width: u32,
    },
    /// A smoothed trajectory's camera that `nerf-infer` refuses.
    #[error("trajectory camera {index}: {source}")]
    Trajectory {
        /// The camera's index in the trajectory.
        index: usize,
        /// Why `nerf-infer` refuses it.
        #[source]
        source: nerf_infer::Error,
    },
}

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

/// Why a plot cannot be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The bundled font, which plotters cannot register.
    #[error("the bundled font cannot be read")]
    Font,
    /// Plotters cannot draw the plot.
    #[error("{}: cannot draw the plot: {source}", path.display())]
    Draw {
        /// The plot's file.
        path: PathBuf,
        /// Plotters' reason.
        #[source]
        source: DrawError,
    },
    /// A drawn bitmap of another size than the plot's.
    #[error("plot buffer size")]
    Buffer,
}

/// `v` as a message shows it: plain up to 10¹⁵, in exponent form for the
/// huge and the tiny (1e308 is not written out in 309 digits).
/// An `f32` is written as its own shortest form (1e30, not the nearest f64).
pub fn number<T: Into<f64> + Copy + fmt::Display + fmt::LowerExp>(v: T) -> String {
    let x: f64 = v.into();
    if x != 0.0 && x.is_finite() && !(1e-4..1e15).contains(&x.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_io_error_names_its_file_and_keeps_the_systems_reason() {
        let e = Error::io(Path::new("out/plot.png"))(std::io::Error::from(std::io::ErrorKind::PermissionDenied));
        let message = e.to_string();
        assert!(
            message.starts_with("out/plot.png: ") && message.to_lowercase().contains("permission denied"),
            "{message}"
        );
        let source = std::error::Error::source(&e).and_then(|s| s.downcast_ref::<std::io::Error>());
        assert_eq!(source.map(|s| s.kind()), Some(std::io::ErrorKind::PermissionDenied));
    }

    #[test]
    fn typed_causes_read_as_one_line_naming_the_field_or_file() {
        let cases: [(Error, &str); 8] = [
            (
                ConfigError::invalid("optimiser.lr", format!("{} must be a step size in (0, 1]", number(2.0f32))).into(),
                "optimiser.lr 2 must be a step size in (0, 1]",
            ),
            (
                ConfigError::Moved { from: "loss.appearance".into(), to: "per_photo.appearance", flat: "appearance".into() }
                    .into(),
                "`loss.appearance` is `per_photo.appearance` (`{\"per_photo\": {\"appearance\": …}}`, or by its flat \
                 name `appearance`)",
            ),
            (
                ConfigError::UnknownName {
                    name: "res".into(),
                    within: Some(crate::config::json::FlatName { flat: "grid_res".into(), section: "grid", field: "res".into() }),
                }
                .into(),
                "unknown field `res`: expected a section (model, features, sampling, grid, optimiser, loss, per_photo) or \
                 a field's flat name (the field `res` of `grid` is `{\"grid\": {\"res\": …}}` or `grid_res`)",
            ),
            (
                CheckpointError::Version { found: 7, min: 18, max: 19 }.into(),
                "not a valid checkpoint: checkpoint version 7, this build reads versions 18 to 19 (written by another build)",
            ),
            (
                CameraError::RaysMiss { share: 0.001234, bounds_min: [-1.0; 3], bounds_max: [1.0; 3], near: 0.5, far: 4.0 }
                    .into(),
                "only 0.12 % of the training rays meet the scene box [-1.0, -1.0, -1.0]..[1.0, 1.0, 1.0] within near 0.5 \
                 .. far 4: the cameras look away from it or the bounds are wrong; check the poses, the aabb/near/far of \
                 the transforms file, or try --scene unbounded",
            ),
            (
                FileError::CameraPath {
                    path: "p.json".into(),
                    reason: CameraPathError::Entry {
                        kind: "keyframe",
                        index: 0,
                        reason: PathEntryError::BottomRow { row: [1.0, 1.0, 1.0, 5.0] },
                    },
                }
                .into(),
                "p.json: keyframe 0: its matrix's bottom row is 1 1 1 5, not 0 0 0 1 (not a rigid transform)",
            ),
            (
                FileError::CameraPath {
                    path: "p.json".into(),
                    reason: CameraPathError::Frames { fps: 5.0, seconds: 1e308, frames: f64::INFINITY },
                }
                .into(),
                "p.json: fps 5 × seconds 1e308 gives inf frames (1 to 100000 are rendered)",
            ),
            (
                FileError::Unreadable {
                    path: "a.json".into(),
                    what: "camera path".into(),
                    reason: ReadError::TooLarge { size: 10, max: 2 },
                }
                .into(),
                "a.json: camera path: 10 bytes, more than the 2 accepted",
            ),
        ];
        for (e, message) in cases {
            assert_eq!(e.to_string(), message);
        }
    }

    #[test]
    fn a_typed_cause_keeps_the_other_crates_error_as_its_source() {
        let io = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        let reason = ReadError::Io { action: "cannot read", source: io };
        let e = Error::from(FileError::Unreadable { path: "m.nerf".into(), what: "model file".into(), reason });
        let read = std::error::Error::source(&e).and_then(|s| s.downcast_ref::<ReadError>());
        assert!(matches!(read, Some(ReadError::Io { action: "cannot read", .. })), "{read:?}");
        let io = read.and_then(std::error::Error::source).and_then(|s| s.downcast_ref::<std::io::Error>());
        assert_eq!(io.map(|s| s.kind()), Some(std::io::ErrorKind::PermissionDenied));
        let e = Error::from(CheckpointError::Decode(postcard::Error::DeserializeUnexpectedEnd));
        let cause = std::error::Error::source(&e).and_then(|s| s.downcast_ref::<CheckpointError>());
        let postcard = cause.and_then(std::error::Error::source).and_then(|s| s.downcast_ref::<postcard::Error>());
        assert_eq!(postcard, Some(&postcard::Error::DeserializeUnexpectedEnd));
        assert!(e.to_string().starts_with("not a valid checkpoint: cannot decode: "), "{e}");
    }
}
