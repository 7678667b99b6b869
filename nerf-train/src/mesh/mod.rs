//! A triangle mesh of a model's density surface: the density sampled on a
//! lattice over the scene's bounds ([`density`]), the level set
//! `σ = threshold` extracted by marching tetrahedra ([`tetra`]), vertex
//! colours from the model, PLY and OBJ output ([`mod@write`]), and the
//! silhouette of the mesh from a camera ([`silhouette`]).

pub mod density;
pub mod silhouette;
pub mod tetra;
pub mod write;

pub use crate::error::MeshError;
use nerf_infer::format::Model;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use tetra::{cross, Edge, Lattice};

/// What to extract.
#[derive(Clone, Copy, Debug)]
pub struct MeshOptions {
    /// Lattice cells per axis over the scene's bounds (2..=1024).
    pub resolution: usize,
    /// Density of the surface, per world unit (> 0).
    pub threshold: f32,
    /// Sample a colour per vertex from the model.
    pub colours: bool,
}

/// An indexed triangle mesh in world units.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions, world units.
    pub positions: Vec<[f32; 3]>,
    /// Vertex colours (sRGB bytes as the model renders them), empty or one
    /// per vertex.
    pub colours: Vec<[u8; 3]>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// Size and closure of a mesh.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct MeshStats {
    /// Vertices.
    pub vertices: usize,
    /// Triangles.
    pub triangles: usize,
    /// Surface area, square world units.
    pub area: f64,
    /// Enclosed volume, cubic world units (the divergence theorem; exact
    /// for a closed mesh).
    pub volume: f64,
    /// Edges not shared by exactly two triangles wound oppositely (0 for
    /// a closed, consistently oriented surface).
    pub open_edges: usize,
}

/// The raw density ([`density::raw_density`]) on the `(r + 1)³` lattice over the bounds (`r` =
/// `resolution`), x fastest, in normalised coordinates (`[−1, 1]³`). The
/// lattice's outer layer is set to 0 so the surface closes at the bounds.
/// `progress` is called with the number of lattice planes done.
pub fn sample_density(m: &Model<'_>, resolution: usize, progress: &(dyn Fn(u64) + Sync)) -> Vec<f32> {
    let n = resolution + 1;
    let step = 2.0 / resolution as f32;
    let done = AtomicU64::new(0);
    let mut values = vec![0f32; n * n * n];
    values.par_chunks_mut(n * n).enumerate().for_each(|(z, plane)| {
        if z > 0 && z < n - 1 {
            let u: Vec<[f32; 3]> = (0..n * n)
                .map(|i| [-1.0 + (i % n) as f32 * step, -1.0 + (i / n) as f32 * step, -1.0 + z as f32 * step])
                .collect();
            density::raw_density(m, &u, plane);
            for (i, v) in plane.iter_mut().enumerate() {
                let (x, y) = (i % n, i / n);
                if x == 0 || y == 0 || x == n - 1 || y == n - 1 {
                    *v = 0.0;
                }
            }
        }
        progress(done.fetch_add(1, Ordering::Relaxed) + 1);
    });
    values
}

/// Extracts the surface `σ = threshold` of `density` (from
/// [`sample_density`] at `resolution`) as a mesh in world units, with
/// colours from the model if asked. Fails on a forward-facing model, an
/// option out of range, or a `density` not of the `(resolution + 1)³` lattice.
pub fn extract(m: &Model<'_>, density: &[f32], opts: MeshOptions) -> Result<Mesh, MeshError> {
    check(m, density.len(), opts)?;
    let lattice = Lattice { n: opts.resolution + 1, values: density };
    let layers: Vec<Vec<[Edge; 3]>> =
        (0..opts.resolution).into_par_iter().map(|z| tetra::layer(&lattice, opts.threshold, z)).collect();
    let (lo, hi) = (m.scene.bounds_min, m.scene.bounds_max);
    let scale = 2.0 / opts.resolution as f32;
    let to_world = |c: [f32; 3]| -> [f32; 3] {
        core::array::from_fn(|k| {
            let u = -1.0 + c[k] * scale;
            0.5 * (lo[k] + hi[k]) + u * 0.5 * (hi[k] - lo[k])
        })
    };
    let mut index: HashMap<Edge, u32> = HashMap::new();
    let mut mesh = Mesh::default();
    for tri in layers.into_iter().flatten() {
        let v = tri.map(|e| {
            *index.entry(e).or_insert_with(|| {
                mesh.positions.push(to_world(lattice.crossing(e, opts.threshold)));
                (mesh.positions.len() - 1) as u32
            })
        });
        mesh.triangles.push(v);
    }
    if opts.colours {
        mesh.colours = vertex_colours(m, &mesh);
    }
    Ok(mesh)
}

fn check(m: &Model<'_>, values: usize, opts: MeshOptions) -> Result<(), MeshError> {
    if m.scene.ndc.is_some() {
        return Err(MeshError::Ndc);
    }
    if !(2..=1024).contains(&opts.resolution) {
        return Err(MeshError::Option(format!("--resolution {} is outside 2..=1024", opts.resolution)));
    }
    if !(opts.threshold.is_finite() && opts.threshold > 0.0) {
        return Err(MeshError::Option(format!("--threshold {} is not a positive density", opts.threshold)));
    }
    let n = opts.resolution + 1;
    if values != n * n * n {
        return Err(MeshError::Option(format!(
            "the density holds {values} values, not the {n}³ = {} of the lattice at --resolution {}: sample it \
             with sample_density at the same resolution",
            n * n * n,
            opts.resolution
        )));
    }
    Ok(())
}

/// Area-weighted vertex normals (unit, outward; zero for a vertex of
/// degenerate triangles only).
pub fn vertex_normals(mesh: &Mesh) -> Vec<[f32; 3]> {
    let mut n = vec![[0f32; 3]; mesh.positions.len()];
    for t in &mesh.triangles {
        let p = t.map(|i| mesh.positions[i as usize]);
        let e1 = core::array::from_fn(|k| p[1][k] - p[0][k]);
        let e2 = core::array::from_fn(|k| p[2][k] - p[0][k]);
        let f = cross(e1, e2);
        for &i in t {
            for k in 0..3 {
                n[i as usize][k] += f[k];
            }
        }
    }
    for v in &mut n {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.0 {
            *v = v.map(|c| c / l);
        }
    }
    n
}

/// The model's colour at each vertex, seen from outside along its normal.
fn vertex_colours(m: &Model<'_>, mesh: &Mesh) -> Vec<[u8; 3]> {
    let normals = vertex_normals(mesh);
    let (lo, hi) = (m.scene.bounds_min, m.scene.bounds_max);
    mesh.positions
        .par_iter()
        .zip(normals.par_iter())
        .map(|(p, nrm)| {
            let u = core::array::from_fn(|k| (2.0 * p[k] - lo[k] - hi[k]) / (hi[k] - lo[k]));
            let dir = if *nrm == [0.0; 3] { [0.0, 0.0, -1.0] } else { nrm.map(|c| -c) };
            density::colour(m, u, dir).map(nerf_infer::composite::to_u8)
        })
        .collect()
}

/// Root of `i` in the union-find forest `parent`, halving the path.
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

impl Mesh {
    /// Drops the connected pieces (triangles joined through shared
    /// vertices) with fewer than `min_fraction` of the largest piece's
    /// triangles: density the training left floating in empty space.
    /// Whole pieces go, so a closed mesh stays closed. Returns the pieces
    /// dropped.
    pub fn drop_small_pieces(&mut self, min_fraction: f64) -> usize {
        let mut parent: Vec<u32> = (0..self.positions.len() as u32).collect();
        for t in &self.triangles {
            let a = find(&mut parent, t[0]);
            for &v in &t[1..] {
                let b = find(&mut parent, v);
                if a != b {
                    parent[b as usize] = a;
                }
            }
        }
        let mut count: HashMap<u32, usize> = HashMap::new();
        let roots: Vec<u32> = self.triangles.iter().map(|t| find(&mut parent, t[0])).collect();
        for &r in &roots {
            *count.entry(r).or_insert(0) += 1;
        }
        let largest = count.values().copied().max().unwrap_or(0);
        let keep = |r: &u32| count[r] as f64 >= min_fraction * largest as f64;
        let dropped = count.keys().filter(|r| !keep(r)).count();
        if dropped == 0 {
            return 0;
        }
        let mut new_index = vec![u32::MAX; self.positions.len()];
        let (mut positions, mut colours, mut triangles) = (Vec::new(), Vec::new(), Vec::new());
        for (t, r) in self.triangles.iter().zip(&roots) {
            if !keep(r) {
                continue;
            }
            triangles.push(t.map(|v| {
                if new_index[v as usize] == u32::MAX {
                    new_index[v as usize] = positions.len() as u32;
                    positions.push(self.positions[v as usize]);
                    if let Some(c) = self.colours.get(v as usize) {
                        colours.push(*c);
                    }
                }
                new_index[v as usize]
            }));
        }
        (self.positions, self.colours, self.triangles) = (positions, colours, triangles);
        dropped
    }

    /// Area, volume and open edges.
    pub fn stats(&self) -> MeshStats {
        let (mut area, mut volume) = (0f64, 0f64);
        let mut directed: HashMap<(u32, u32), i32> = HashMap::with_capacity(self.triangles.len() * 3 / 2);
        for t in &self.triangles {
            let p = t.map(|i| self.positions[i as usize].map(f64::from));
            let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
            let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
            let c = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
            area += 0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
            let q = [
                p[1][1] * p[2][2] - p[1][2] * p[2][1],
                p[1][2] * p[2][0] - p[1][0] * p[2][2],
                p[1][0] * p[2][1] - p[1][1] * p[2][0],
            ];
            volume += (p[0][0] * q[0] + p[0][1] * q[1] + p[0][2] * q[2]) / 6.0;
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                // +1 for a → b, −1 for b → a: a closed, consistently wound surface sums to 0 on every edge
                let (key, s) = if a < b { ((a, b), 1) } else { ((b, a), -1) };
                *directed.entry(key).or_insert(0) += s;
            }
        }
        let open_edges = directed.values().filter(|&&s| s != 0).count();
        MeshStats { vertices: self.positions.len(), triangles: self.triangles.len(), area, volume, open_edges }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TrainConfig;

    #[test]
    fn a_density_not_of_the_lattice_at_the_resolution_is_refused_naming_it() {
        let cfg = TrainConfig::fast().with(|c| {
            (c.model.depth, c.model.width, c.model.view_width) = (2, 16, 8);
            c.model.skips.clear();
        });
        let scene = nerf_infer::format::Scene::blender(1.0, 2.0, 6.0);
        let bytes = crate::export::random_model(&cfg, scene, 1, 1.0).unwrap().to_bytes().unwrap();
        let m = Model::from_bytes(&bytes).unwrap();
        let opts = MeshOptions { resolution: 4, threshold: 1.0, colours: false };
        let e = extract(&m, &[0.0; 100], opts).unwrap_err().to_string();
        assert!(
            e.starts_with("the density holds 100 values, not the 5³ = 125 of the lattice at --resolution 4"),
            "{e}"
        );
        assert!(extract(&m, &[0.0; 125], opts).unwrap().triangles.is_empty());
    }
}
