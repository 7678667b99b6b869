//! The renderer of `nerf-infer` as a WebAssembly module with a plain C
//! ABI (no JavaScript glue generator): the page that `nerf web` writes
//! loads a model into the module's memory, sets a camera and renders
//! rectangles of pixels into an RGBA buffer it draws on a canvas.
//!
//! Every pixel goes through [`RayRenderer::render_ray`] with the pixel's
//! own coordinates as its jitter key and is rounded to 8 bits by
//! [`nerf_infer::to_u8`] ([`nerf_infer::Pixel::to_rgb888`]), as `nerf render` does on the host, so a frame in the
//! browser is bit for bit the host's PNG.
//!
//! Calls, in order: [`nerf_alloc`] a buffer for the model file and write
//! it there; [`nerf_load`] it; write the camera into [`nerf_camera_ptr`]
//! and [`nerf_set_camera`]; [`nerf_render`] rectangles
//! ([`nerf_set_early_stop`] trades exactness for speed). A call that fails
//! returns 0 (or a null pointer) and leaves a message at
//! [`nerf_error_ptr`] / [`nerf_error_len`].

use nerf_infer::{AnyRenderer, AnyScratch, Camera, Model, RayRenderer, RenderOptions};
use std::cell::RefCell;

/// The loaded model's renderer and its working memory (blocks of 8
/// samples).
struct Active(AnyRenderer<'static, 'static>, Box<AnyScratch<8>>);

/// Everything the module holds between calls.
#[derive(Default)]
struct State {
    model: Option<&'static Model<'static>>,
    active: Option<Active>,
    camera: Option<Camera>,
    camera_in: [f32; 16],
    rgba: Vec<u8>,
    error: String,
}

thread_local! {
    static STATE: RefCell<State> = RefCell::new(State::default());
}

fn fail(s: &mut State, msg: impl Into<String>) -> u32 {
    s.error = msg.into();
    0
}

/// A buffer of `len` bytes for the caller to fill (the model file), owned
/// by the module from now on.
#[no_mangle]
pub extern "C" fn nerf_alloc(len: usize) -> *mut u8 {
    let mut v = vec![0u8; len].into_boxed_slice();
    let p = v.as_mut_ptr();
    core::mem::forget(v);
    p
}

/// Decodes the model in the buffer `ptr` (from [`nerf_alloc`] with
/// `len`) and makes its renderer (f32 models: the f32 path; int16 and
/// int8: the fixed-point path) with the model's own sample counts and no
/// early termination, as `nerf render`. Returns 1 (f32), 2 (fixed point)
/// or 0 (not a valid model).
///
/// # Safety
/// `ptr` and `len` are a buffer [`nerf_alloc`] returned, filled, and not
/// passed here before.
#[no_mangle]
pub unsafe extern "C" fn nerf_load(ptr: *mut u8, len: usize) -> u32 {
    // SAFETY: the caller passes a boxed slice of `len` bytes leaked by nerf_alloc, once
    let bytes: &'static [u8] = Box::leak(unsafe { Box::from_raw(core::ptr::slice_from_raw_parts_mut(ptr, len)) });
    STATE.with_borrow_mut(|s| {
        let model: &'static Model<'static> = match Model::from_bytes(bytes) {
            Ok(m) => Box::leak(Box::new(m)),
            Err(e) => return fail(s, format!("model: {e}")),
        };
        s.model = Some(model);
        renderer(s, 0.0)
    })
}

/// Makes the loaded model's renderer with early termination at
/// transmittance `early_stop` (`[0, 1)`; 0 renders every sample). Returns
/// as [`nerf_load`].
#[no_mangle]
pub extern "C" fn nerf_set_early_stop(early_stop: f32) -> u32 {
    STATE.with_borrow_mut(|s| renderer(s, early_stop))
}

fn renderer(s: &mut State, early_stop: f32) -> u32 {
    let Some(model) = s.model else { return fail(s, "no model") };
    let opts = RenderOptions { early_stop, ..RenderOptions::from_model(model) };
    match AnyRenderer::new(model, opts) {
        Ok(r) => {
            let kind = if r.is_fixed() { 2 } else { 1 };
            s.active = Some(Active(r, Box::new(r.scratch())));
            kind
        }
        Err(e) => fail(s, format!("renderer: {e}")),
    }
}

/// Where the caller writes the camera before [`nerf_set_camera`]: 16 f32,
/// `fx fy cx cy` in pixels, then the camera-to-world matrix `[R | t]`
/// row by row (OpenGL axes: the camera looks along −z, y up).
#[no_mangle]
pub extern "C" fn nerf_camera_ptr() -> *mut f32 {
    STATE.with_borrow_mut(|s| s.camera_in.as_mut_ptr())
}

/// Takes the camera written at [`nerf_camera_ptr`] for a `width × height`
/// image. Returns 1, or 0 if it is not a camera (sizes, focal lengths,
/// a rotation that is not rigid).
#[no_mangle]
pub extern "C" fn nerf_set_camera(width: u32, height: u32) -> u32 {
    STATE.with_borrow_mut(|s| {
        let c = s.camera_in;
        let m: [[f32; 4]; 3] = core::array::from_fn(|r| core::array::from_fn(|k| c[4 + 4 * r + k]));
        match Camera::new(width, height, c[0], c[1], c[2], c[3], m) {
            Ok(cam) => {
                s.camera = Some(cam);
                1
            }
            Err(e) => fail(s, format!("camera: {e}")),
        }
    })
}

/// Renders the pixels `x0..x0 + w`, `y0..y0 + h` of the camera's image
/// into an RGBA buffer (row-major, 8 bits, alpha 255) and returns it
/// (valid until the next call); null if no model or camera is set or the
/// rectangle leaves the image.
#[no_mangle]
pub extern "C" fn nerf_render(x0: u32, y0: u32, w: u32, h: u32) -> *const u8 {
    STATE.with_borrow_mut(|s| {
        let State { active, camera, rgba, error, .. } = s;
        let (Some(active), Some(cam)) = (active.as_mut(), camera.as_ref()) else {
            *error = "no model or no camera".into();
            return core::ptr::null();
        };
        if x0.checked_add(w).is_none_or(|x| x > cam.width) || y0.checked_add(h).is_none_or(|y| y > cam.height) {
            *error = format!("rectangle {x0},{y0} {w}x{h} leaves the {}x{} image", cam.width, cam.height);
            return core::ptr::null();
        }
        rgba.clear();
        // a model with a pixel footprint renders the camera's pixels
        let (pixel, rect) = (cam.pixel_angle(), (x0, y0, w, h));
        let Active(r, scratch) = active;
        let r = r.with_pixel(pixel);
        render_rgba(cam, rect, rgba, |o, d, xy| r.render_ray(o, d, xy, scratch));
        rgba.as_ptr()
    })
}

/// Appends to `rgba` the pixels `x0..x0 + w`, `y0..y0 + h` (row-major,
/// 8 bits, alpha 255) that `render` gives for each of `cam`'s rays
/// (origin, direction, pixel).
fn render_rgba(
    cam: &Camera,
    (x0, y0, w, h): (u32, u32, u32, u32),
    rgba: &mut Vec<u8>,
    mut render: impl FnMut(nerf_infer::Vec3, nerf_infer::Vec3, (u32, u32)) -> nerf_infer::Pixel,
) {
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let (o, d) = cam.ray(x, y);
            rgba.extend(render(o, d, (x, y)).to_rgb888());
            rgba.push(255);
        }
    }
}

/// The last error message (UTF-8), [`nerf_error_len`] bytes.
#[no_mangle]
pub extern "C" fn nerf_error_ptr() -> *const u8 {
    STATE.with_borrow(|s| s.error.as_ptr())
}

/// Length of the last error message in bytes.
#[no_mangle]
pub extern "C" fn nerf_error_len() -> usize {
    STATE.with_borrow(|s| s.error.len())
}
