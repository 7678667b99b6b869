//! The project's built-in scene: an analytic ray tracer (a base slab, a
//! matte red sphere, a glossy green sphere, a blue box; Blinn-Phong
//! highlights make the colour view-dependent), rendered with 2×2
//! supersampling and written to disk as a Blender dataset (RGBA PNGs on a
//! transparent background, 16-bit depth PNGs in millimetres of camera-space
//! z, `-1` = background stored as 0) and as an LLFF dataset
//! (`poses_bounds.npy` + `images/`, forward-facing, on black).

use super::{npy::write_npy_f64, DataError};
use glam::{Vec3, Vec3A};
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
    let f = (-eye).normalize();
    let right = f.cross(Vec3::Z).normalize();
    let up = right.cross(f);
    let back = -f;
    [[right.x, up.x, back.x, eye.x], [right.y, up.y, back.y, eye.y], [right.z, up.z, back.z, eye.z]]
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
        p.0 = c.map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
    }
    crate::atomic::write_png(path, &img).map_err(|e| DataError::new(path, format!("cannot write PNG: {e}")))
}

fn save_depth(path: &Path, w: u32, h: u32, z: &[f32]) -> Result<(), DataError> {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(w, h, |x, y| {
        image::Luma([(z[(y * w + x) as usize] * 1000.0).round().min(65535.0) as u16])
    });
    crate::atomic::write_png(path, &img).map_err(|e| DataError::new(path, format!("cannot write PNG: {e}")))
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
        crate::atomic::write(&path, serde_json::to_string_pretty(&json).expect("json").as_bytes())
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
