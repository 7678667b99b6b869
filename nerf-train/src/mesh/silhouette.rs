//! The silhouette of a mesh from a pinhole camera: which pixel centres a
//! triangle covers, and its agreement (intersection over union) with a
//! mask.

use super::Mesh;
use nerf_infer::Camera;

/// Coverage of each pixel (row-major, `camera.width × camera.height`): a
/// pixel is covered when its centre falls inside a triangle's projection
/// (edges included). Triangles with a vertex at or behind the camera's
/// plane are skipped.
pub fn silhouette(mesh: &Mesh, camera: &Camera) -> Vec<bool> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let mut cover = vec![false; w * h];
    let world_to_cam = camera.rotation.transpose();
    let proj: Vec<Option<[f32; 2]>> = mesh
        .positions
        .iter()
        .map(|p| {
            let c = world_to_cam * (nerf_infer::Vec3::from(*p) - camera.position);
            // the camera looks along −z, image y points down
            (c.z < 0.0).then(|| [camera.cx + camera.fx * c.x / -c.z, camera.cy - camera.fy * c.y / -c.z])
        })
        .collect();
    for t in &mesh.triangles {
        let [Some(a), Some(b), Some(c)] = t.map(|i| proj[i as usize]) else { continue };
        let area = edge_fn(a, b, c);
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        let x0 = (a[0].min(b[0]).min(c[0]) - 0.5).ceil().max(0.0) as usize;
        let y0 = (a[1].min(b[1]).min(c[1]) - 0.5).ceil().max(0.0) as usize;
        let x1 = ((a[0].max(b[0]).max(c[0]) - 0.5).floor()).min(w as f32 - 1.0);
        let y1 = ((a[1].max(b[1]).max(c[1]) - 0.5).floor()).min(h as f32 - 1.0);
        if x1 < 0.0 || y1 < 0.0 {
            continue;
        }
        for y in y0..=y1 as usize {
            for x in x0..=x1 as usize {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let (e0, e1, e2) = (edge_fn(b, c, p), edge_fn(c, a, p), edge_fn(a, b, p));
                let inside =
                    if area > 0.0 { e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0 } else { e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0 };
                cover[y * w + x] |= inside;
            }
        }
    }
    cover
}

/// Twice the signed area of triangle `a b p`.
fn edge_fn(a: [f32; 2], b: [f32; 2], p: [f32; 2]) -> f32 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Intersection over union of two masks of the same size (1 when both are
/// empty).
///
/// # Panics
/// If `a` and `b` differ in length.
pub fn iou(a: &[bool], b: &[bool]) -> f64 {
    assert_eq!(a.len(), b.len(), "masks of different sizes");
    let inter = a.iter().zip(b).filter(|(x, y)| **x && **y).count();
    let union = a.iter().zip(b).filter(|(x, y)| **x || **y).count();
    if union == 0 {
        1.0
    } else {
        inter as f64 / union as f64
    }
}
