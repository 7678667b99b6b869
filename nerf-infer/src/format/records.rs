//! The model's records: scheme, scene, encoding, topology, samples,
//! provenance and the training capture's split.

use serde::{Deserialize, Serialize};

/// Numeric scheme of a network's weights. With the `clap` feature it is a
/// `clap::ValueEnum` spelt by its bits (`32`, `16`, `8`), as `nerf export
/// --bits` takes it.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Scheme {
    /// f32 weights and biases; rendered by the f32 path.
    #[cfg_attr(feature = "clap", value(name = "32"))]
    F32,
    /// int16 weights with per-output-channel scales; i64 accumulation.
    #[cfg_attr(feature = "clap", value(name = "16"))]
    I16,
    /// int8 weights with per-output-channel scales; i32 accumulation.
    #[cfg_attr(feature = "clap", value(name = "8"))]
    I8,
}

impl Scheme {
    /// Bytes per weight element.
    pub const fn weight_bytes(self) -> usize {
        match self {
            Scheme::F32 => 4,
            Scheme::I16 => 2,
            Scheme::I8 => 1,
        }
    }
    /// Weight bits (32, 16 or 8).
    pub const fn bits(self) -> u32 {
        self.weight_bytes() as u32 * 8
    }
    /// True for the integer schemes rendered by the fixed-point path.
    pub const fn is_fixed(self) -> bool {
        !matches!(self, Scheme::F32)
    }
}

/// Camera convention of the poses the model was trained with.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraConvention {
    /// OpenGL/Blender: camera looks down −z, +y up, +x right.
    OpenGl,
}

/// Normalised-device-coordinate ray space of forward-facing (LLFF) scenes.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Ndc {
    /// Focal length of the training cameras, in pixels.
    pub focal: f32,
    /// Training image width in pixels.
    pub width: f32,
    /// Training image height in pixels.
    pub height: f32,
}

/// Where the scene is and how rays see it.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    /// Axis-aligned bounds of the content, world units (NDC units if `ndc`).
    pub bounds_min: [f32; 3],
    /// Upper corner of the bounds; each component > `bounds_min`.
    pub bounds_max: [f32; 3],
    /// Near plane distance along the ray parameter `t` (units of `|d|`, `d.z = −1` in camera space).
    pub near: f32,
    /// Far plane distance, > `near`.
    pub far: f32,
    /// Composite on white (true, Blender) or black (false).
    pub white_background: bool,
    /// Pose convention.
    pub convention: CameraConvention,
    /// Rays are mapped to NDC before sampling (forward-facing scenes).
    pub ndc: Option<Ndc>,
    /// Space beyond the bounds is contracted into a shell around them
    /// (format version 5). Not stored here: set from [`Model::unbounded`](super::Model::unbounded)
    /// when a model is decoded.
    #[serde(skip)]
    pub unbounded: Option<Unbounded>,
}

impl Scene {
    /// An object scene in the Blender convention: the cube of half-width
    /// `half` (world units) around the origin, rays sampled from `near` to
    /// `far` (units of `t`), composited on white; bounded, no NDC. Blender's
    /// synthetic scenes are `blender(1.5, 2.0, 6.0)`.
    pub fn blender(half: f32, near: f32, far: f32) -> Self {
        Self {
            bounds_min: [-half; 3],
            bounds_max: [half; 3],
            near,
            far,
            white_background: true,
            convention: CameraConvention::OpenGl,
            ndc: None,
            unbounded: None,
        }
    }

    /// The background's grey level in `[0, 1]`: 1 on white, 0 on black.
    pub fn background(&self) -> f32 {
        if self.white_background {
            1.0
        } else {
            0.0
        }
    }
}

/// Unbounded space (mip-NeRF 360's contraction, with the max norm): a
/// normalised position `u` (bounds ↦ `[−1, 1]³`) with `m = ‖u‖∞` enters the
/// grid and the network as `u/2` when `m ≤ 1` and as `u/m · (1 − 1/(2m))`
/// beyond, so all of space fits `[−1, 1]³` and the bounds fill its inner
/// half. Rays are not clipped to the bounds; samples are spaced evenly in
/// `t` up to [`Unbounded::linear_until`] and evenly in `1/t` beyond it, up
/// to the scene's `far`.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Unbounded {
    /// Ray parameter `T` (units of `t`, > 0, below `far`) where the sample
    /// spacing turns from even in `t` to even in `1/t`: a sample at `s ∈
    /// [0, 1)` sits at `t = 2Ts` below `s = 1/2` and at `T/(2(1 − s))` above.
    pub linear_until: f32,
}

/// Features averaged over each sample's pixel footprint (format version
/// 10; models with a feature grid, not forward-facing). A sample at `t` on
/// a ray through a pixel of angular size `a` (radians: 1/focal length in
/// pixels) takes the mean of the feature grid's values at three points
/// around it, `ρ·t·(cos θ·u + sin θ·v)` in world units for θ = 0, 2π/3,
/// 4π/3, `u`, `v` a unit basis perpendicular to the ray
/// ([`crate::camera::Ray::with_footprint`]) and `ρ = a/√6`: the points
/// spread as far across the ray as a pixel-wide box (variance `a²t²/12`
/// along each axis). γ(x) and the occupancy grid stay at the sample.
/// Renderers take `a` from the camera, or `pixel` at the model's own
/// resolution.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    /// Angular size of a training pixel, radians (finite, in `(0, 0.1]`):
    /// the footprint a renderer uses unless told the camera's.
    pub pixel: f32,
}

impl Footprint {
    /// Whether `pixel` is finite and in `(0, 0.1]`.
    pub fn is_valid(&self) -> bool {
        self.pixel.is_finite() && self.pixel > 0.0 && self.pixel <= 0.1
    }
}

/// The circle a video's cameras follow around the scene, fitted to the
/// training cameras (format version 9): around `centre` in the plane
/// perpendicular to `up`, at `radius` from its axis and `height` above
/// `centre` along it, starting at `azimuth`, each camera looking at
/// `centre` with `up` as its up. World units (the model's frame); a model
/// without one orbits as its scene suggests.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq)]
pub struct FittedOrbit {
    /// The point the cameras look at.
    pub centre: [f32; 3],
    /// The orbit's up, a unit vector (within 10⁻³).
    pub up: [f32; 3],
    /// Distance from the axis through `centre` along `up` (> 0).
    pub radius: f32,
    /// Height above `centre` along `up` (either sign, |height| ≤ 100·radius).
    pub height: f32,
    /// Horizontal field of view, radians (0 < fov_x < π).
    pub fov_x: f32,
    /// Azimuth of the first camera, radians in `[−π, π]`, from `u₁` (+x
    /// made perpendicular to `up`, +y when |up·x| > 0.9) towards
    /// `u₂ = up × u₁`: where the training cameras are, on average.
    pub azimuth: f32,
}

impl FittedOrbit {
    /// Whether every field is finite and in its range.
    pub fn is_valid(&self) -> bool {
        let scalars = [self.radius, self.height, self.fov_x, self.azimuth];
        let finite = self.centre.iter().chain(&self.up).chain(&scalars).all(|v| v.is_finite());
        let norm2 = self.up.iter().map(|v| v * v).sum::<f32>();
        finite
            && (norm2 - 1.0).abs() < 2e-3
            && self.radius > 0.0
            && self.height.abs() <= 100.0 * self.radius
            && self.fov_x > 0.0
            && self.fov_x < core::f32::consts::PI
            && self.azimuth.abs() <= core::f32::consts::PI
    }
}

/// Positional encoding parameters (NeRF eq. 4): per coordinate p,
/// `γ(p) = (p, sin(2⁰πp), cos(2⁰πp), …, sin(2^{L−1}πp), cos(2^{L−1}πp))`.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Encoding {
    /// Frequencies `L` for positions (0..=16; 0 disables the encoding).
    pub pos_freqs: u8,
    /// Frequencies `L` for view directions (0..=16).
    pub dir_freqs: u8,
    /// Whether the raw coordinate is included before the sin/cos features.
    pub include_input: bool,
    /// Fixed path: raw positions enter the first layer as i16 with this many
    /// fractional bits (0..=15). Ignored by the f32 path.
    pub raw_frac_bits: u8,
    /// Values of the learned feature grid appended to γ(x) (`levels ×
    /// width` of [`Model::features`](super::Model::features), 0 without one). Not stored: set from
    /// the feature grid when a model is decoded.
    #[serde(skip)]
    pub grid_dim: u8,
}

impl Encoding {
    /// Width of the encoded position: γ(x), then the feature grid's values.
    pub const fn pos_dim(&self) -> usize {
        self.gamma_dim() + self.grid_dim as usize
    }
    /// Width of γ(x) alone.
    pub const fn gamma_dim(&self) -> usize {
        3 * (self.include_input as usize + 2 * self.pos_freqs as usize)
    }
    /// Width of the encoded direction.
    pub const fn dir_dim(&self) -> usize {
        3 * (self.include_input as usize + 2 * self.dir_freqs as usize)
    }
}

/// The MLP's shape (NeRF fig. 7, configurable).
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Topology {
    /// Trunk layers (each `width` wide, ReLU), ≥ 1.
    pub depth: u8,
    /// Trunk width (1..=256).
    pub width: u16,
    /// Bit `i` set: trunk layer `i` (≥ 1) takes `[γ(x), h]` as input.
    pub skip_mask: u16,
    /// View-dependent colour branch (feature layer + view layer) on or off.
    pub view_dependent: bool,
    /// Width of the view layer (1..=256); ignored without the branch.
    pub view_width: u16,
}

impl Topology {
    /// Number of layers a network of this topology has.
    pub const fn layer_count(&self) -> usize {
        self.depth as usize + if self.view_dependent { 4 } else { 2 }
    }
    /// Whether trunk layer `i` takes the encoded position as extra input.
    pub const fn is_skip(&self, i: usize) -> bool {
        i > 0 && i < 16 && self.skip_mask & (1 << i) != 0
    }
}

/// Default sample counts per ray.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Samples {
    /// Stratified samples evaluated by the coarse network (2..=256 with a
    /// fine network, 2..=1024 without).
    pub coarse: u16,
    /// Importance samples added for the fine network (0..=256; 0: no fine pass).
    pub fine: u16,
}

/// Provenance recorded by the trainer.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Meta {
    /// Dataset downscale factor used for training (1 = full resolution).
    pub train_downscale: u16,
    /// Training iterations run.
    pub iterations: u32,
}

/// How the scene's frame was chosen when the capture was loaded for training.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Framing {
    /// Given by the capture's own files (bounds or an `aabb` in them).
    Files,
    /// Fitted: a box around what the cameras look at.
    Object,
    /// Forward-facing: NDC rays.
    Forward,
    /// Fitted: a box holding the object and the cameras, space beyond it contracted.
    Unbounded,
}

/// How the training capture was split and framed (format version 4), so
/// that evaluation and rendering load the capture as training did and
/// score only views the model never saw.
#[derive(Serialize, Deserialize, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capture {
    /// Every `holdout`-th view in capture order (0, N, 2N, …) was held out
    /// of training (1..=100 000; LLFF, COLMAP, instant-ngp).
    pub holdout: u32,
    /// Views in the whole capture, training and held out.
    pub views: u32,
    /// CRC-32 ([`crc32`](super::crc32)) of the held-out views' names (image file stems),
    /// each followed by `\n`, in capture order.
    pub held_out_crc: u32,
    /// How the scene's frame was chosen.
    pub framing: Framing,
    /// Rays followed the photos' lens distortion (false: treated as pinholes).
    pub lens: bool,
}

impl Capture {
    /// Largest valid [`Capture::holdout`].
    pub const MAX_HOLDOUT: u32 = 100_000;
}
