//! The project's built-in scene: an analytic ray tracer (a base slab, a
//! matte red sphere, a glossy green sphere, a blue box; Blinn-Phong
//! highlights make the colour view-dependent), rendered with 2×2
//! supersampling and written to disk as a Blender dataset (RGBA PNGs on a
//! transparent background, 16-bit depth PNGs in millimetres of camera-space
//! z, `-1` = background stored as 0) and as an LLFF dataset
//! (`poses_bounds.npy` + `images/`, forward-facing, on black; or all
//! around the scene inside a coloured room).

mod shot;

use super::npy::write_npy_f64;
use super::types::DataError;
use glam::{Vec3, Vec3A};
pub use shot::write_llff_room;
use shot::{save_jpeg, Shot};
use std::path::Path;

/// Scene geometry is z-up (as Blender) inside `[-1, 1]³`.
const LIGHT: Vec3 = Vec3::new(0.45, -0.35, 0.82);

#[derive(Clone, Copy)]
struct Material {
    albedo: Vec3,
    spec: f32,
    shininess: f32,
}

enum Shape {
    Sphere { c: Vec3, r: f32 },
    Cuboid { lo: Vec3, hi: Vec3 },
}

struct Object {
    shape: Shape,
    mat: Material,
}

fn objects() -> [Object; 4] {
    [
        Object {
            shape: Shape::Cuboid { lo: Vec3::new(-0.9, -0.9, -0.75), hi: Vec3::new(0.9, 0.9, -0.6) },
            mat: Material { albedo: Vec3::new(0.82, 0.74, 0.52), spec: 0.05, shininess: 8.0 },
        },
        Object {
            shape: Shape::Sphere { c: Vec3::new(-0.42, -0.15, -0.22), r: 0.38 },
            mat: Material { albedo: Vec3::new(0.85, 0.18, 0.12), spec: 0.0, shininess: 1.0 },
        },
        Object {
            shape: Shape::Sphere { c: Vec3::new(0.45, 0.25, -0.28), r: 0.32 },
            mat: Material { albedo: Vec3::new(0.12, 0.55, 0.22), spec: 0.7, shininess: 40.0 },
        },
        Object {
            shape: Shape::Cuboid { lo: Vec3::new(-0.1, 0.3, -0.6), hi: Vec3::new(0.3, 0.7, 0.2) },
            mat: Material { albedo: Vec3::new(0.15, 0.3, 0.85), spec: 0.25, shininess: 16.0 },
        },
    ]
}

/// Nearest hit of a unit-direction ray: (distance, normal, material).
fn trace(o: Vec3, d: Vec3) -> Option<(f32, Vec3, Material)> {
    let mut best: Option<(f32, Vec3, Material)> = None;
    for obj in objects() {
        let hit = match obj.shape {
            Shape::Sphere { c, r } => {
                let oc = o - c;
                let b = oc.dot(d);
                let disc = b * b - (oc.length_squared() - r * r);
                if disc < 0.0 {
                    None
                } else {
                    let t = -b - disc.sqrt();
                    (t > 1e-4).then(|| (t, (o + t * d - c) / r))
                }
            }
            Shape::Cuboid { lo, hi } => {
                let inv = Vec3A::ONE / Vec3A::from(d);
                let t0 = (Vec3A::from(lo) - Vec3A::from(o)) * inv;
                let t1 = (Vec3A::from(hi) - Vec3A::from(o)) * inv;
                let tmin = t0.min(t1);
                let tmax = t0.max(t1);
                let (tn, tf) = (tmin.max_element(), tmax.min_element());
                (tn <= tf && tn > 1e-4).then(|| {
                    let n = if tn == tmin.x {
                        Vec3::new(-d.x.signum(), 0.0, 0.0)
                    } else if tn == tmin.y {
                        Vec3::new(0.0, -d.y.signum(), 0.0)
                    } else {
                        Vec3::new(0.0, 0.0, -d.z.signum())
                    };
                    (tn, n)
                })
            }
        };
        if let Some((t, n)) = hit {
            if best.as_ref().is_none_or(|b| t < b.0) {
                best = Some((t, n, obj.mat));
            }
        }
    }
    best
}

/// Colour seen along a unit ray, or `None` for background.
fn shade(o: Vec3, d: Vec3) -> Option<(Vec3, f32)> {
    let (t, n, m) = trace(o, d)?;
    let l = LIGHT.normalize();
    let p = o + t * d;
    let lit = trace(p + n * 1e-3, l).is_none();
    let ndl = n.dot(l).max(0.0) * if lit { 1.0 } else { 0.15 };
    let h = (l - d).normalize();
    let spec = if lit { m.spec * n.dot(h).max(0.0).powf(m.shininess) } else { 0.0 };
    let c = m.albedo * (0.3 + 0.7 * ndl) + Vec3::splat(spec);
    Some((c.clamp(Vec3::ZERO, Vec3::ONE), t))
}

/// A camera-to-world matrix at `eye` looking at the origin, z up.
pub fn look_at(eye: Vec3) -> [[f32; 4]; 3] {
    nerf_infer::camera::look_at_pose(eye, Vec3::ZERO, Vec3::Z)
}

/// Renders the scene: RGBA (straight alpha) and camera-space depth (0 = none).
pub fn render(width: u32, height: u32, focal: f32, c2w: &[[f32; 4]; 3]) -> (Vec<[f32; 4]>, Vec<f32>) {
    let col = |c: usize| Vec3::new(c2w[0][c], c2w[1][c], c2w[2][c]);
    let (rx, ry, rz, eye) = (col(0), col(1), col(2), col(3));
    let mut rgba = Vec::with_capacity((width * height) as usize);
    let mut depth = Vec::with_capacity((width * height) as usize);
    for j in 0..height {
        for i in 0..width {
            let mut acc = Vec3::ZERO;
            let mut cover = 0.0;
            let mut z = 0.0f32;
            for s in 0..4 {
                let px = i as f32 + 0.25 + 0.5 * (s % 2) as f32 - width as f32 / 2.0;
                let py = j as f32 + 0.25 + 0.5 * (s / 2) as f32 - height as f32 / 2.0;
                let dc = Vec3::new(px / focal, -py / focal, -1.0);
                let d = rx * dc.x + ry * dc.y + rz * dc.z;
                if let Some((c, t)) = shade(eye, d.normalize()) {
                    acc += c;
                    cover += 0.25;
                    z = z.max(t / d.length());
                }
            }
            let a = cover;
            let c = if a > 0.0 { acc / (4.0 * a) } else { Vec3::ZERO };
            rgba.push([c.x, c.y, c.z, a]);
            depth.push(z);
        }
    }
    (rgba, depth)
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> DataError + '_ {
    move |e| DataError::new(path, format!("cannot write: {e}"))
}

fn save_rgba(path: &Path, w: u32, h: u32, px: &[[f32; 4]]) -> Result<(), DataError> {
    let mut img = image::RgbaImage::new(w, h);
    for (p, c) in img.pixels_mut().zip(px) {
        p.0 = c.map(nerf_infer::composite::to_u8);
    }
    crate::util::atomic::write_png(path, &img).map_err(|e| DataError::new(path, format!("cannot write PNG: {e}")))
}

fn save_depth(path: &Path, w: u32, h: u32, z: &[f32]) -> Result<(), DataError> {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w, h, |x, y| {
        image::Luma([(z[(y * w + x) as usize] * 1000.0).round().min(65535.0) as u16])
    });
    crate::util::atomic::write_png(path, &img).map_err(|e| DataError::new(path, format!("cannot write PNG: {e}")))
}

/// Camera positions on the upper hemisphere (golden spiral), radius 4.
fn hemisphere(n: usize, offset: f32) -> Vec<Vec3> {
    (0..n)
        .map(|k| {
            let u = (k as f32 + 0.5 + offset) / n as f32;
            let elev = (12.0f32 + 60.0 * u).to_radians();
            let az = (k as f32 + offset) * 2.399_963 + 0.3;
            4.0 * Vec3::new(elev.cos() * az.cos(), elev.cos() * az.sin(), elev.sin())
        })
        .collect()
}

/// Size and view counts of the generated datasets.
#[derive(Clone, Copy, Debug)]
pub struct SceneSpec {
    /// Image side in pixels.
    pub size: u32,
    /// Training views.
    pub train: usize,
    /// Validation views.
    pub val: usize,
    /// Test views.
    pub test: usize,
}

impl Default for SceneSpec {
    fn default() -> Self {
        Self { size: 64, train: 48, val: 6, test: 6 }
    }
}

/// Field of view (radians) of the generated cameras, as lego's.
pub const FOV_X: f32 = 0.691_111_2;

/// Writes the Blender-layout dataset into `dir` (created if missing).
pub fn write_blender(dir: &Path, spec: SceneSpec) -> Result<(), DataError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let focal = 0.5 * spec.size as f32 / (0.5 * FOV_X).tan();
    for (split, n, offset) in [("train", spec.train, 0.0), ("val", spec.val, 0.37), ("test", spec.test, 0.71)] {
        let sub = dir.join(split);
        std::fs::create_dir_all(&sub).map_err(io(&sub))?;
        let mut frames = Vec::new();
        for (k, eye) in hemisphere(n, offset).into_iter().enumerate() {
            let c2w = look_at(eye);
            let (rgba, depth) = render(spec.size, spec.size, focal, &c2w);
            save_rgba(&sub.join(format!("r_{k}.png")), spec.size, spec.size, &rgba)?;
            save_depth(&sub.join(format!("r_{k}_depth.png")), spec.size, spec.size, &depth)?;
            let m: Vec<Vec<f32>> = c2w.iter().map(|r| r.to_vec()).chain([vec![0.0, 0.0, 0.0, 1.0]]).collect();
            frames.push(serde_json::json!({ "file_path": format!("./{split}/r_{k}"), "transform_matrix": m }));
        }
        let json = serde_json::json!({ "camera_angle_x": FOV_X, "near": 2.0, "far": 6.0, "aabb": [[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]], "frames": frames });
        let path = dir.join(format!("transforms_{split}.json"));
        crate::util::atomic::write(&path, serde_json::to_string_pretty(&json).expect("json").as_bytes())
            .map_err(io(&path))?;
    }
    Ok(())
}

/// Writes the LLFF-layout dataset (forward-facing views) into `dir`.
pub fn write_llff(dir: &Path, spec: SceneSpec) -> Result<(), DataError> {
    let img_dir = dir.join("images");
    std::fs::create_dir_all(&img_dir).map_err(io(&img_dir))?;
    let n = spec.train + spec.val;
    let (w, h) = (spec.size, spec.size * 3 / 4);
    let focal = 0.5 * w as f32 / (0.5 * FOV_X).tan();
    let mut rows = Vec::new();
    for k in 0..n {
        // a 2-D grid of viewpoints in front of the scene
        let gx = (k % 5) as f32 / 4.0 - 0.5;
        let gy = (k / 5) as f32 / ((n as f32 / 5.0).ceil() - 1.0).max(1.0) - 0.5;
        let eye = Vec3::new(0.6 * gx, -4.0, 1.2 + 0.5 * gy);
        let c2w = look_at(eye);
        let (rgba, _) = render(w, h, focal, &c2w);
        let rgb: Vec<[f32; 4]> = rgba.iter().map(|p| [p[0] * p[3], p[1] * p[3], p[2] * p[3], 1.0]).collect();
        save_rgba(&img_dir.join(format!("img_{k:03}.png")), w, h, &rgb)?;
        // LLFF columns: [down, right, back, t, (h, w, f)]
        let col = |c: usize| [c2w[0][c] as f64, c2w[1][c] as f64, c2w[2][c] as f64];
        let (right, up, back, t) = (col(0), col(1), col(2), col(3));
        let hwf = [h as f64, w as f64, focal as f64];
        for r in 0..3 {
            rows.extend_from_slice(&[-up[r], right[r], back[r], t[r], hwf[r]]);
        }
        let dist = (eye.length()) as f64;
        rows.extend_from_slice(&[dist - 1.6, dist + 1.6]);
    }
    let path = dir.join("poses_bounds.npy");
    write_npy_f64(&path, n, 17, &rows).map_err(io(&path))
}

/// Colour of the room around the scene (a sphere of radius 12 about the
/// origin, in coloured bands) seen along the unit ray `o + t d` from inside.
fn room(o: Vec3, d: Vec3) -> (Vec3, f32) {
    let b = o.dot(d);
    let t = -b + (b * b - (o.length_squared() - 144.0)).max(0.0).sqrt();
    let p = o + t * d;
    let az = p.y.atan2(p.x);
    let c = Vec3::new(0.55 + 0.35 * (3.0 * az).sin(), 0.5 + 0.3 * (0.8 * p.z).cos(), 0.45 + 0.35 * (5.0 * az).cos());
    (c, t)
}

/// How [`write_colmap`] writes the sparse model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColmapText {
    /// `cameras.bin`, `images.bin`, `points3D.bin`.
    Binary,
    /// `cameras.txt`, `images.txt`, `points3D.txt`.
    Text,
}

/// Writes the scene as a COLMAP capture into `dir`: `images/` (JPEG,
/// quality 95) and `sparse/0/`, `spec.train + spec.val` cameras on the
/// hemisphere around the scene. Even views use an OPENCV camera of
/// `size × size` with a little barrel distortion (the images show it),
/// odd views a PINHOLE camera of `size × 3/4 size`. With `room`, a
/// coloured room surrounds the scene (a 360° capture with a background);
/// without, the background is black. Sparse points are surface points
/// seen by the cameras.
pub fn write_colmap(dir: &Path, spec: SceneSpec, format: ColmapText, with_room: bool) -> Result<(), DataError> {
    use super::colmap_io::{
        write_model_bin, write_model_txt, CameraModel, ColmapCamera, ColmapImage, ColmapPoint, Reconstruction,
    };
    use super::lens::Lens;
    let img_dir = dir.join("images");
    let model_dir = dir.join("sparse").join("0");
    for d in [&img_dir, &model_dir] {
        std::fs::create_dir_all(d).map_err(io(d))?;
    }
    let s = spec.size as f64;
    let f = 0.5 * s / (0.5 * FOV_X as f64).tan();
    let (k1, k2) = (-0.05, 0.01);
    let cams = [
        (
            ColmapCamera {
                id: 1,
                model: CameraModel::Opencv,
                width: spec.size as u64,
                height: spec.size as u64,
                params: vec![f, f, s / 2.0, s / 2.0, k1, k2, 0.0, 0.0],
            },
            Lens::opencv(k1, k2, 0.0, 0.0),
        ),
        (
            ColmapCamera {
                id: 2,
                model: CameraModel::Pinhole,
                width: spec.size as u64,
                height: (spec.size * 3 / 4) as u64,
                params: vec![0.9 * f, 0.9 * f, s / 2.0, 3.0 * s / 8.0],
            },
            Lens::Pinhole,
        ),
    ];
    let mut rec = Reconstruction { cameras: cams.iter().map(|c| c.0.clone()).collect(), ..Default::default() };
    let n = spec.train + spec.val;
    for (k, eye) in hemisphere(n, 0.0).into_iter().enumerate() {
        let (cam, lens) = &cams[k % 2];
        let c2w = look_at(eye);
        let col = |c: usize| Vec3::new(c2w[0][c], c2w[1][c], c2w[2][c]);
        let (rx, ry, rz) = (col(0), col(1), col(2));
        let (w, h) = (cam.width as u32, cam.height as u32);
        let (fx, cx, cy) = (cam.params[0], cam.params[2], cam.params[3]);
        let shot = Shot { eye, c2w, size: (w, h), fx, centre: (cx, cy), lens: *lens, with_room };
        let img = shot.photo();
        let name = format!("img_{k:03}.jpg");
        let path = img_dir.join(&name);
        save_jpeg(&path, &img)?;
        // world-to-camera in OpenCV axes: rows of R are right, down, forward
        let r = glam::DMat3::from_cols(rx.as_dvec3(), -ry.as_dvec3(), -rz.as_dvec3()).transpose();
        let q = glam::DQuat::from_mat3(&r);
        let t = -(r * eye.as_dvec3());
        rec.images.push(ColmapImage {
            id: k as u32 + 1,
            qvec: [q.w, q.x, q.y, q.z],
            tvec: t.to_array(),
            camera_id: cam.id,
            name,
        });
        rec.points.extend(shot.surface_points().map(|(p, rgb)| ColmapPoint {
            xyz: p.as_dvec3().to_array(),
            rgb,
            error: 0.5,
            track_len: 2,
        }));
    }
    let res = match format {
        ColmapText::Binary => write_model_bin(&model_dir, &rec),
        ColmapText::Text => write_model_txt(&model_dir, &rec),
    };
    res.map_err(io(&model_dir))
}
