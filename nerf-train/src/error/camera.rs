//! Why a capture's cameras cannot be used ([`CameraError`]).

/// Why a capture's cameras cannot be trained on or rendered from.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// A COLMAP camera with another number of parameters than its model has.
    #[error("{model} needs {needs} parameters, found {found}")]
    ParameterCount {
        /// The camera's model, as COLMAP names it.
        model: &'static str,
        /// How many parameters the model has.
        needs: usize,
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
        "camera model {model} is not supported (SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, \
         FULL_OPENCV, OPENCV_FISHEYE, SIMPLE_RADIAL_FISHEYE, RADIAL_FISHEYE, SIMPLE_FISHEYE, FISHEYE, \
         THIN_PRISM_FISHEYE, FOV are; undistort the images with colmap image_undistorter)"
    )]
    Unsupported {
        /// The camera's model, as COLMAP names it.
        model: &'static str,
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
    /// A view whose pixels, mask or opacities are not one per pixel of its camera.
    #[error(
        "view `{view}`: {len} {what} for its {width}x{height} camera: a view holds one per pixel, row-major (its \
         mask and opacities may be empty)"
    )]
    PixelCount {
        /// The view's name.
        view: String,
        /// What is miscounted: `pixels`, `mask values` or `opacities`.
        what: &'static str,
        /// How many it holds.
        len: usize,
        /// The camera's width, pixels.
        width: u32,
        /// The camera's height, pixels.
        height: u32,
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
