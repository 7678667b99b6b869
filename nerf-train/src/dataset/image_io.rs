//! Image reading (PNG, JPEG, TIFF, WebP, BMP, TGA: 8/16-bit, grey, RGB, RGBA; EXIF
//! orientation applied) with compositing and area downscaling, masks, and
//! PNG writing.

use super::types::DataError;
use std::path::Path;

/// Longest side of a photo the loaders decode, pixels (a 200-megapixel
/// phone's photo is 16 320 wide).
pub const MAX_SIDE: u32 = 20_000;

/// Most pixels of a photo the loaders decode (as RGBA f32, 16 bytes each:
/// 2.4 GB; a 108-megapixel phone photo has 108 million).
pub const MAX_PIXELS: u64 = 150_000_000;

/// The decoder of the image at `path` (format from its content), with
/// limits on its size and allocations, its header read; and its EXIF orientation.
fn decoder(path: &Path) -> Result<(impl image::ImageDecoder, image::metadata::Orientation), DataError> {
    use image::ImageDecoder;
    let bad = |e: &dyn std::fmt::Display| DataError::new(path, format!("cannot read image: {e}"));
    if !path.is_file() {
        return Err(DataError::new(path, "cannot read image: no such file (or not a regular file)"));
    }
    // the decoders' own allocations bounded; the size is checked below, on the header, with the numbers named
    let mut limits = image::Limits::default();
    // (16-bit RGBA: 8 bytes a pixel)
    limits.max_alloc = Some(8 * MAX_PIXELS);
    let mut reader = image::ImageReader::open(path).map_err(|e| bad(&e))?.with_guessed_format().map_err(|e| bad(&e))?;
    reader.limits(limits);
    let mut decoder = reader.into_decoder().map_err(|e| bad(&e))?;
    let (w, h) = decoder.dimensions();
    if w as u64 * h as u64 > MAX_PIXELS || w > MAX_SIDE || h > MAX_SIDE {
        return Err(DataError::new(
            path,
            format!(
                "cannot read image: its header says {w}x{h} pixels, more than the {MAX_SIDE} a side and \
                 {MAX_PIXELS} in all the loaders decode (a damaged file?)"
            ),
        ));
    }
    let orientation = decoder.orientation().unwrap_or(image::metadata::Orientation::NoTransforms);
    Ok((decoder, orientation))
}

/// The size of the image at `path` from its header alone: as
/// [`read_upright`] decodes it (after its EXIF orientation) if `upright`,
/// else as stored.
pub fn image_size(path: &Path, upright: bool) -> Result<(u32, u32), DataError> {
    use image::metadata::Orientation::*;
    use image::ImageDecoder;
    let (d, o) = decoder(path)?;
    let (w, h) = d.dimensions();
    let turned = upright && matches!(o, Rotate90 | Rotate270 | Rotate90FlipH | Rotate270FlipH);
    Ok(if turned { (h, w) } else { (w, h) })
}

/// Decodes the image at `path` (format from its content) upright: the
/// rotation or mirroring its EXIF orientation tag asks for is applied, as
/// a photo viewer shows it. A header claiming more than [`MAX_SIDE`]
/// pixels a side or [`MAX_PIXELS`] in all is refused before any pixel is
/// decoded.
pub fn read_upright(path: &Path) -> Result<image::DynamicImage, DataError> {
    read_image(path, true)
}

/// [`read_upright`], or with `upright` false the pixels as stored (the
/// EXIF orientation ignored, as COLMAP reads photos).
fn read_image(path: &Path, upright: bool) -> Result<image::DynamicImage, DataError> {
    let bad = |e: &dyn std::fmt::Display| DataError::new(path, format!("cannot read image: {e}"));
    let (decoder, orientation) = decoder(path)?;
    let mut img = image::DynamicImage::from_decoder(decoder).map_err(|e| bad(&e))?;
    if upright {
        img.apply_orientation(orientation);
    }
    Ok(img)
}

/// [`load_rgb`] of the pixels as stored, the EXIF orientation ignored: the
/// photos of a COLMAP reconstruction, whose poses were computed on them so.
pub fn load_rgb_stored(path: &Path, downscale: u32, white_bg: bool) -> Result<(u32, u32, Vec<[f32; 3]>), DataError> {
    rgba_of(path, read_image(path, false)?, downscale, white_bg).map(|(w, h, rgb, _)| (w, h, rgb))
}

/// Loads an image as RGB in `[0, 1]`: RGBA is composited on white if
/// `white_bg` (the Blender convention) or black; then each `n × n` block is
/// averaged (`n = downscale`; a remainder at the right/bottom is cropped).
/// Returns (width, height, pixels).
pub fn load_rgb(path: &Path, downscale: u32, white_bg: bool) -> Result<(u32, u32, Vec<[f32; 3]>), DataError> {
    load_rgba(path, downscale, white_bg).map(|(w, h, rgb, _)| (w, h, rgb))
}

/// Loads an image's alpha channel in `[0, 1]` (1 for an image without
/// one), averaged over `n × n` blocks as [`load_rgb`] averages colour.
/// Returns (width, height, alpha).
pub fn load_alpha(path: &Path, downscale: u32) -> Result<(u32, u32, Vec<f32>), DataError> {
    let (w, h, rgb, alpha) = load_rgba(path, downscale, false)?;
    Ok((w, h, alpha.unwrap_or_else(|| vec![1.0; rgb.len()])))
}

/// [`load_rgb`] and, for an image with an alpha channel, its opacity in
/// `[0, 1]` averaged over the same blocks (`None` for an opaque format).
/// Block averages keep compositing linear: the block's colour on another
/// background `b` is `rgb + (1 − alpha)·(b − background)`.
/// Returns (width, height, pixels, alpha).
#[allow(clippy::type_complexity)]
pub fn load_rgba(
    path: &Path,
    downscale: u32,
    white_bg: bool,
) -> Result<(u32, u32, Vec<[f32; 3]>, Option<Vec<f32>>), DataError> {
    rgba_of(path, read_upright(path)?, downscale, white_bg)
}

/// [`load_rgba`] of the decoded `img` of `path`.
#[allow(clippy::type_complexity)]
fn rgba_of(
    path: &Path,
    img: image::DynamicImage,
    downscale: u32,
    white_bg: bool,
) -> Result<(u32, u32, Vec<[f32; 3]>, Option<Vec<f32>>), DataError> {
    let has_alpha = img.color().has_alpha();
    let img = img.to_rgba32f();
    let (w, h) = img.dimensions();
    let n = downscale.max(1);
    let (ow, oh) = (w / n, h / n);
    if ow == 0 || oh == 0 {
        return Err(DataError::new(path, format!("image {w}x{h} is smaller than the downscale factor {n}")));
    }
    let bg = if white_bg { 1.0 } else { 0.0 };
    let mut out = vec![[0f32; 3]; (ow * oh) as usize];
    let mut alpha = vec![0f32; if has_alpha { out.len() } else { 0 }];
    let inv = 1.0 / (n * n) as f32;
    for y in 0..oh {
        for x in 0..ow {
            let mut acc = [0f32; 4];
            for dy in 0..n {
                for dx in 0..n {
                    let p = img.get_pixel(x * n + dx, y * n + dy).0;
                    for c in 0..3 {
                        acc[c] += p[c] * p[3] + bg * (1.0 - p[3]);
                    }
                    acc[3] += p[3];
                }
            }
            let i = (y * ow + x) as usize;
            out[i] = [acc[0] * inv, acc[1] * inv, acc[2] * inv];
            if has_alpha {
                alpha[i] = acc[3] * inv;
            }
        }
    }
    Ok((ow, oh, out, has_alpha.then_some(alpha)))
}

/// Reads a mask (nerfstudio's `mask_path`: a pixel whose first channel is 0
/// is left out, any other value keeps it) at `downscale` as the photo it
/// belongs to is loaded (each `n × n` block, the remainder at the
/// right/bottom cropped): a block is kept only if every pixel in it is, so
/// no kept pixel mixes in what the mask hides. Read as stored, or after its
/// EXIF orientation if `upright` (as the photo). `photo` is the photo's file
/// and size (width, height, full resolution, as read); a mask of another
/// size is refused. Returns one flag per loaded pixel, row-major, true where kept.
pub fn load_mask(path: &Path, downscale: u32, upright: bool, photo: (&Path, u32, u32)) -> Result<Vec<bool>, DataError> {
    let img = read_image(path, upright)?.to_rgba16();
    let (w, h) = img.dimensions();
    if (w, h) != (photo.1, photo.2) {
        return Err(DataError::new(
            path,
            format!(
                "mask is {w}x{h} but its photo {} is {}x{}: a mask must have its photo's size",
                photo.0.display(),
                photo.1,
                photo.2
            ),
        ));
    }
    let n = downscale.max(1);
    let (ow, oh) = (w / n, h / n);
    let mut out = vec![true; (ow * oh) as usize];
    for (i, keep) in out.iter_mut().enumerate() {
        let (x, y) = (i as u32 % ow, i as u32 / ow);
        *keep = (0..n * n).all(|k| img.get_pixel(x * n + k % n, y * n + k / n).0[0] != 0);
    }
    Ok(out)
}

/// Writes RGB in `[0, 1]` as an 8-bit PNG, atomically (temp file + rename).
pub fn save_png_rgb(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> Result<(), DataError> {
    let mut buf = image::RgbImage::new(width, height);
    for (p, c) in buf.pixels_mut().zip(rgb) {
        p.0 = c.map(nerf_infer::composite::to_u8);
    }
    crate::util::atomic::write_png(path, &buf).map_err(|e| DataError::new(path, format!("cannot write PNG: {e}")))
}
