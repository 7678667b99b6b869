//! Mesh files: binary little-endian PLY (positions as float, colours as
//! uchar `red green blue`, faces as `uchar` count + `int` indices), or
//! OBJ text (`v x y z [r g b]` with colours in `[0, 1]`, the extension
//! MeshLab and Blender read; `f` with 1-based indices).

use super::Mesh;
use std::fmt::Write as _;

/// The mesh as a binary PLY file.
pub fn ply(mesh: &Mesh) -> Vec<u8> {
    let colours = !mesh.colours.is_empty();
    let mut head = String::from("ply\nformat binary_little_endian 1.0\ncomment nerf mesh\n");
    let _ = writeln!(head, "element vertex {}", mesh.positions.len());
    head.push_str("property float x\nproperty float y\nproperty float z\n");
    if colours {
        head.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    let _ = writeln!(head, "element face {}", mesh.triangles.len());
    head.push_str("property list uchar int vertex_indices\nend_header\n");
    let mut out = head.into_bytes();
    out.reserve(mesh.positions.len() * 15 + mesh.triangles.len() * 13);
    for (i, p) in mesh.positions.iter().enumerate() {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
        if colours {
            out.extend_from_slice(&mesh.colours[i]);
        }
    }
    for t in &mesh.triangles {
        out.push(3);
        for &i in t {
            out.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    out
}

/// The mesh as an OBJ file.
pub fn obj(mesh: &Mesh) -> Vec<u8> {
    let mut s = String::from("# nerf mesh\n");
    for (i, p) in mesh.positions.iter().enumerate() {
        let _ = write!(s, "v {} {} {}", p[0], p[1], p[2]);
        if let Some(c) = mesh.colours.get(i) {
            let _ = write!(s, " {:.4} {:.4} {:.4}", c[0] as f32 / 255.0, c[1] as f32 / 255.0, c[2] as f32 / 255.0);
        }
        s.push('\n');
    }
    for t in &mesh.triangles {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s.into_bytes()
}
