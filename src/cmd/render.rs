//! `nerf render`: PNGs of a split's views (through each photo's lens) or of
//! a path around the scene, plus an animated GIF for paths: per view the
//! colour, the depth as 16-bit PNG in scene units (the step written to
//! `depth.json`) and as a colour-mapped preview, and the opacity.

use super::{decode, load_split, num_in, read_model, with_threads, CaptureArgs, CmdError, CmdResult};
use nerf_infer::format::Scene;
use nerf_infer::Orbit;
use nerf_infer::{Camera, RenderOptions};
use nerf_train::dataset::save_png_rgb;
use nerf_train::dataset::Split;
use nerf_train::eval::{render_view, PixelRays, Rendered};
use nerf_train::path::{read_camera_path, smooth_trajectory, to_camera_path};
use std::path::{Path, PathBuf};

/// Arguments of `nerf render`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("views").required(true).args(["split", "orbit", "trajectory", "camera_path"])))]
pub struct Args {
    /// Model file (.nerf).
    pub(crate) model: PathBuf,
    /// The dataset whose views (`--split`) or trajectory (`--trajectory`) to render.
    #[arg(long)]
    pub(crate) data: Option<PathBuf>,
    /// Render this split's views, each through its photo's lens.
    #[arg(long, value_enum, requires = "data")]
    pub(crate) split: Option<Split>,
    #[command(flatten)]
    pub(crate) capture: CaptureArgs,
    /// Render N views on an orbit around the scene: the circle fitted to the training cameras (their centre, up,
    /// radius, height and field of view; `nerf info` shows it), or 30° above the bounds' centre for a model without
    /// one; a small circle in front for forward-facing scenes.
    #[arg(long, value_name = "1..=10000", value_parser = num_in(1usize, 10_000))]
    pub(crate) orbit: Option<usize>,
    /// Render N views along the capture's own camera trajectory (its views in name order, smoothed), with the
    /// field of view of its first camera.
    #[arg(long, requires = "data", value_name = "1..=10000", value_parser = num_in(1usize, 10_000))]
    pub(crate) trajectory: Option<usize>,
    /// Render the cameras of a nerfstudio camera_path.json: its rendered camera list, or without one its keyframes
    /// interpolated over fps × seconds frames as nerfstudio does (poses in the model's frame, as the
    /// camera_path.json that --orbit and --trajectory write).
    #[arg(long)]
    pub(crate) camera_path: Option<PathBuf>,
    /// Image width in pixels of --orbit (square), --trajectory and --camera-path frames.
    #[arg(long, default_value_t = 100, value_name = "1..=4096", value_parser = num_in(1u32, 4096))]
    pub(crate) size: u32,
    /// Output directory.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Replace what nerf wrote in the output folder before (another command's outputs, as its
    /// `.nerf-outputs` record lists them); files nerf did not write are never removed.
    #[arg(long)]
    pub(crate) force: bool,
    /// Worker threads (0: all cores).
    #[arg(long, default_value_t = 0, value_name = "0..=1024", value_parser = num_in(0usize, 1024))]
    pub(crate) threads: usize,
}

impl Args {
    /// `nerf render MODEL --orbit N --out OUT` with every other flag at its default.
    pub fn orbit(model: PathBuf, n: usize, out: PathBuf) -> Self {
        Self {
            model,
            data: None,
            split: None,
            capture: CaptureArgs::default(),
            orbit: Some(n),
            trajectory: None,
            camera_path: None,
            size: 100,
            out,
            force: false,
            threads: 0,
        }
    }
}

/// Writes `NAME_depth.png` (16-bit, `depth / step`), `NAME_depth_preview.png`
/// (near..far colour-mapped, near warm; in an unbounded scene, whose `far`
/// is 1000 times its
/// [`nerf_infer::format::Unbounded::linear_until`], spaced as its samples
/// are: even up to `linear_until`, then in 1/depth) and `NAME_opacity.png`
/// (8-bit grey).
fn save_depth_opacity(out: &Path, name: &str, r: &Rendered, scene: &Scene, step: f32) -> CmdResult {
    let path = out.join(format!("{name}_depth.png"));
    let d16 = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(r.width, r.height, |x, y| {
        let d = r.depth[(y * r.width + x) as usize];
        image::Luma([(d / step).round().clamp(0.0, 65535.0) as u16])
    });
    nerf_train::util::atomic::write_png(&path, &d16).map_err(CmdError::io(&path, "cannot write PNG"))?;
    let spacing = |d: f32| scene.unbounded.map_or(d, |u| nerf_infer::unbounded::s_of_t(d, u.linear_until));
    let (near, far) = (spacing(scene.near), spacing(scene.far));
    let preview: Vec<[f32; 3]> =
        r.depth.iter().map(|&d| colour_map(1.0 - (spacing(d) - near) / (far - near))).collect();
    save_png_rgb(&out.join(format!("{name}_depth_preview.png")), r.width, r.height, &preview)?;
    let grey: Vec<[f32; 3]> = r.opacity.iter().map(|&a| [a; 3]).collect();
    Ok(save_png_rgb(&out.join(format!("{name}_opacity.png")), r.width, r.height, &grey)?)
}

/// A blue → green → yellow → red colour map of `v` in `[0, 1]`.
fn colour_map(v: f32) -> [f32; 3] {
    let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
    let r = (1.5 - (4.0 * v - 3.0).abs()).clamp(0.0, 1.0);
    let g = (1.5 - (4.0 * v - 2.0).abs()).clamp(0.0, 1.0);
    let b = (1.5 - (4.0 * v - 1.0).abs()).clamp(0.0, 1.0);
    [r, g, b]
}

/// Runs `nerf render`.
pub fn run(a: Args) -> CmdResult {
    let bytes = read_model(&a.model)?;
    let model = decode(&a.model, &bytes)?;
    if let Some(d) = &a.data {
        super::refuse_inside(&a.out, "--out", d)?;
    }
    if let Some(p) = &a.camera_path {
        // the render writes the expanded path as OUT/camera_path.json: never over the file it reads
        if super::refuse_same_file(&a.out.join("camera_path.json"), "--out", p).is_err() {
            return Err(CmdError::Flag {
                flag: "--out",
                reason: format!(
                    "{}: would replace the --camera-path file {} with the expanded camera list; choose another \
                     --out",
                    a.out.display(),
                    p.display()
                ),
            });
        }
    }
    let ds = a.capture.downscale_for(&model);
    let path: Option<Vec<Camera>> = match (&a.data, a.orbit, a.trajectory, &a.camera_path) {
        (_, Some(n), _, _) => {
            let o = Orbit::of(&model);
            let cams = (0..n).map(|k| o.camera(k as f32 / n as f32, a.size, a.size));
            let orbit = |e: nerf_infer::Error| CmdError::File {
                path: a.model.clone(),
                reason: format!("the model's orbit: {e}"),
            };
            Some(cams.collect::<Result<_, _>>().map_err(orbit)?)
        }
        (Some(dir), _, Some(n), _) => {
            // every view: holdout 1 makes the whole capture the test split
            let capture = CaptureArgs { llffhold: None, ..a.capture }.for_model(&model, &a.model)?;
            let data = load_split(dir, Split::Test, ds, CaptureArgs { llffhold: Some(1), ..capture })?;
            super::same_frame(&data, &model, &a.model)?;
            let views = data.views;
            let mut views: Vec<_> = views.into_iter().map(|v| (v.name, v.camera)).collect();
            views.sort_by(|x, y| x.0.cmp(&y.0));
            let cams: Vec<Camera> = views.into_iter().map(|v| v.1).collect();
            Some(smooth_trajectory(&cams, n, a.size).map_err(CmdError::file(dir))?)
        }
        (_, _, _, Some(file)) => Some(read_camera_path(file, a.size)?),
        _ => None,
    };
    let cams: Vec<(String, Box<dyn PixelRays>)> = match (&a.data, a.split, &path) {
        (_, _, Some(path)) => {
            let stem = if a.orbit.is_some() { "orbit" } else { "frame" };
            path.iter()
                .enumerate()
                .map(|(k, c)| (format!("{stem}_{k:03}"), Box::new(*c) as Box<dyn PixelRays>))
                .collect()
        }
        (Some(dir), Some(split), _) => {
            let data = load_split(dir, split, ds, a.capture.for_model(&model, &a.model)?)?;
            super::same_frame(&data, &model, &a.model)?;
            data.views.into_iter().map(|v| (v.name.clone(), Box::new(v) as Box<dyn PixelRays>)).collect()
        }
        _ => {
            return Err(CmdError::Usage(
                "give --data DIR --split S, --orbit N, --data DIR --trajectory N, or --camera-path FILE".into(),
            ))
        }
    };
    // a frame's size, checked before any is allocated: a camera path's aspect sets its height
    if let Some((name, (w, h))) = cams.iter().map(|(n, c)| (n, c.size())).find(|(_, (w, h))| *w.max(h) > MAX_SIDE) {
        return Err(CmdError::Usage(format!(
            "{name}: a frame of {w}×{h} pixels (at most {MAX_SIDE} on a side){}; give a smaller --size",
            if a.camera_path.is_some() { ", from the camera path's aspect and --size" } else { "" }
        )));
    }
    let opts = RenderOptions::from_model(&model);
    let (near, far) = (model.scene.near, model.scene.far);
    // depth PNG step: far in 65535 steps
    let step = far / 65535.0;
    let units = if model.scene.ndc.is_some() { "NDC t (forward-facing scene)" } else { "scene units (camera-space z)" };
    let meta = serde_json::json!({ "depth_png_step": step, "depth_units": units, "near": near, "far": far });
    // a path's frames are kept for its GIF (RGBA, 4 bytes a pixel): checked before any is rendered
    let gif_bytes = path.as_ref().map_or(0, |p| p.iter().map(|c| 4 * c.width as u64 * c.height as u64).sum::<u64>());
    if gif_bytes > MAX_GIF_BYTES {
        return Err(CmdError::Usage(format!(
            "the GIF of {} frames at --size {} would need {:.1} GB in memory (at most {} GB): fewer frames or a smaller \
             --size",
            cams.len(),
            a.size,
            gif_bytes as f64 / 1e9,
            MAX_GIF_BYTES / 1_000_000_000
        )));
    }
    let _out = super::outdir::OutDir::claim(&a.out, "--out", "render", super::outdir::Earlier::Replace, a.force)?;
    // stopped between views: the folder's record names what was written, which the same command replaces
    let _stopping = super::interrupt::catch_while();
    super::write_atomic(&a.out.join("depth.json"), meta.to_string().as_bytes())?;
    if let Some(path) = &path {
        // the path as nerfstudio's camera_path.json, to edit and render again with --camera-path
        let json = to_camera_path(path, 12.5);
        super::write_atomic(&a.out.join("camera_path.json"), json.to_string().as_bytes())?;
    }
    let pb = super::progress(cams.len() as u64, "{bar:30} {pos}/{len} views ({eta})");
    let mut frames = Vec::new();
    for (k, (name, cam)) in cams.iter().enumerate() {
        if super::interrupt::received() {
            return Err(CmdError::Interrupted(format!(
                "interrupted after {k} of {} views; the same command replaces them",
                cams.len()
            )));
        }
        let r =
            with_threads(a.threads, || render_view(&model, opts, cam.as_ref()))?.map_err(CmdError::file(&a.model))?;
        save_png_rgb(&a.out.join(format!("{name}.png")), r.width, r.height, &r.rgb)?;
        save_depth_opacity(&a.out, name, &r, &model.scene, step)?;
        if path.is_some() {
            frames.push(gif_frame(&r));
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    if path.is_some() {
        let gif = if a.orbit.is_some() { "orbit.gif" } else { "path.gif" };
        write_gif(&a.out.join(gif), frames)?;
    }
    eprintln!("wrote {} views to {}", cams.len(), a.out.display());
    Ok(())
}

/// Most pixels on a side of a rendered frame.
const MAX_SIDE: u32 = 16_384;

/// Most memory the frames of one GIF may take (4 GB).
const MAX_GIF_BYTES: u64 = 4_000_000_000;

/// A render as an opaque 8-bit RGBA frame.
fn gif_frame(r: &Rendered) -> image::RgbaImage {
    let mut img = image::RgbaImage::new(r.width, r.height);
    for (p, c) in img.pixels_mut().zip(&r.rgb) {
        let q = c.map(nerf_infer::composite::to_u8);
        p.0 = [q[0], q[1], q[2], 255];
    }
    img
}

/// Writes `frames` as an endlessly looping GIF at `path` (80 ms a frame), atomically.
fn write_gif(path: &Path, frames: Vec<image::RgbaImage>) -> CmdResult {
    let encoding =
        |e: image::ImageError| CmdError::File { path: path.to_path_buf(), reason: format!("cannot write GIF: {e}") };
    let mut bytes = Vec::new();
    {
        let mut enc = image::codecs::gif::GifEncoder::new_with_speed(&mut bytes, 10);
        enc.set_repeat(image::codecs::gif::Repeat::Infinite).map_err(encoding)?;
        for img in frames {
            let frame = image::Frame::from_parts(img, 0, 0, image::Delay::from_numer_denom_ms(80, 1));
            enc.encode_frame(frame).map_err(encoding)?;
        }
    }
    nerf_train::util::atomic::write(path, &bytes).map_err(CmdError::io(path, "cannot write GIF"))
}
