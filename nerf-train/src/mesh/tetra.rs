//! Marching cubes in its tetrahedral form: each lattice cell is split into
//! six tetrahedra around its main diagonal (the Freudenthal split, the
//! same in every cell, so neighbouring cells cut their shared faces the
//! same way) and each tetrahedron crossed by the level set gives one
//! triangle or two. There are no ambiguous cases, and vertices are shared
//! by lattice edge, so a level set that does not reach the lattice's
//! border comes out closed.

/// The six tetrahedra of a cell, as corner numbers (bit 0: +x, bit 1:
/// +y, bit 2: +z); each is a path 0 → one axis → two axes → 7.
const TETRAHEDRA: [[usize; 4]; 6] =
    [[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];

/// A lattice edge: its two lattice points, lower index first.
pub type Edge = (u32, u32);

/// A scalar field on a lattice of `n × n × n` points, x fastest.
pub struct Lattice<'a> {
    /// Points per axis (≥ 2).
    pub n: usize,
    /// Values, `n³`.
    pub values: &'a [f32],
}

impl Lattice<'_> {
    /// Index of point `(x, y, z)`.
    pub fn index(&self, x: usize, y: usize, z: usize) -> u32 {
        ((z * self.n + y) * self.n + x) as u32
    }

    /// Lattice coordinates of point `i`.
    pub fn coords(&self, i: u32) -> [f32; 3] {
        let i = i as usize;
        let n = self.n;
        [(i % n) as f32, (i / n % n) as f32, (i / (n * n)) as f32]
    }

    /// Where the level `level` crosses edge `e`, in lattice coordinates
    /// (linear interpolation of the two values; computed from the edge
    /// alone, so every cell sharing it agrees).
    pub fn crossing(&self, e: Edge, level: f32) -> [f32; 3] {
        let (a, b) = (self.coords(e.0), self.coords(e.1));
        let (va, vb) = (self.values[e.0 as usize], self.values[e.1 as usize]);
        let t = if va == vb { 0.5 } else { ((level - va) / (vb - va)).clamp(0.0, 1.0) };
        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])]
    }
}

fn edge(a: u32, b: u32) -> Edge {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a × b`.
pub fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The triangles of the cells in layer `z` (cells `z..z + 1` along z) of
/// the surface `value = level`, "inside" being `value > level`; each
/// triangle as three edges, wound counter-clockwise seen from outside.
pub fn layer(l: &Lattice<'_>, level: f32, z: usize) -> Vec<[Edge; 3]> {
    let mut out = Vec::new();
    for y in 0..l.n - 1 {
        for x in 0..l.n - 1 {
            let corner: [u32; 8] = core::array::from_fn(|c| l.index(x + (c & 1), y + (c >> 1 & 1), z + (c >> 2)));
            let inside = corner.map(|i| l.values[i as usize] > level);
            if inside.iter().all(|&v| v) || inside.iter().all(|&v| !v) {
                continue;
            }
            for t in TETRAHEDRA {
                tetrahedron(l, t.map(|c| corner[c]), t.map(|c| inside[c]), &mut out);
            }
        }
    }
    out
}

/// The one or two triangles of one tetrahedron (points `p`, which are
/// inside the level set `ins`), wound by the sign of the tetrahedron's
/// volume in lattice coordinates (exact small integers): each crossing
/// lies on a segment from a point on one side, so the triangle keeps that
/// point's view of the opposite face, and no flat or tiny triangle can
/// turn the wrong way.
fn tetrahedron(l: &Lattice<'_>, p: [u32; 4], ins: [bool; 4], out: &mut Vec<[Edge; 3]>) {
    let mut order = [0usize; 4];
    let mut k = 0;
    for want in [true, false] {
        for j in 0..4 {
            if ins[j] == want {
                order[k] = j;
                k += 1;
            }
        }
    }
    let inside = ins.iter().filter(|&&v| v).count();
    // the inside points first; the winding below is for a positively oriented `q`
    let q = order.map(|j| p[j]);
    let c = q.map(|i| l.coords(i));
    let positive = dot(sub(c[1], c[0]), cross(sub(c[2], c[0]), sub(c[3], c[0]))) > 0.0;
    let (a, b, cc, d) = (q[0], q[1], q[2], q[3]);
    let mut emit = |t: [Edge; 3]| out.push(if positive { t } else { [t[0], t[2], t[1]] });
    match inside {
        // a inside: the triangle faces away from it
        1 => emit([edge(a, b), edge(a, cc), edge(a, d)]),
        // d outside: the triangle faces it
        3 => emit([edge(d, a), edge(d, b), edge(d, cc)]),
        // a, b inside: the quad on ac, ad, bd, bc, facing away from them
        2 => {
            emit([edge(a, cc), edge(a, d), edge(b, d)]);
            emit([edge(a, cc), edge(b, d), edge(b, cc)]);
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Triangles of the whole lattice.
    fn all(l: &Lattice<'_>, level: f32) -> Vec<[Edge; 3]> {
        (0..l.n - 1).flat_map(|z| layer(l, level, z)).collect()
    }

    /// Signed volume (lattice units³) and the number of edges not used
    /// once in each direction.
    fn volume_and_open(l: &Lattice<'_>, tris: &[[Edge; 3]], level: f32) -> (f64, usize) {
        let mut ids = std::collections::HashMap::new();
        let mut directed = std::collections::HashMap::new();
        let mut vol = 0f64;
        for t in tris {
            let v = t.map(|e| {
                let k = ids.len();
                *ids.entry(e).or_insert(k)
            });
            let p = t.map(|e| l.crossing(e, level).map(f64::from));
            let q = [
                p[1][1] * p[2][2] - p[1][2] * p[2][1],
                p[1][2] * p[2][0] - p[1][0] * p[2][2],
                p[1][0] * p[2][1] - p[1][1] * p[2][0],
            ];
            vol += (p[0][0] * q[0] + p[0][1] * q[1] + p[0][2] * q[2]) / 6.0;
            for k in 0..3 {
                let (a, b) = (v[k], v[(k + 1) % 3]);
                *directed.entry((a.min(b), a.max(b))).or_insert(0i32) += if a < b { 1 } else { -1 };
            }
        }
        (vol, directed.values().filter(|&&s| s != 0).count())
    }

    #[test]
    fn a_sphere_comes_out_closed_outward_and_of_its_volume() {
        let n = 33;
        let r = 10.0f32;
        let values: Vec<f32> = (0..n * n * n)
            .map(|i| {
                let (x, y, z) = ((i % n) as f32 - 16.2, (i / n % n) as f32 - 15.9, (i / (n * n)) as f32 - 16.1);
                r - (x * x + y * y + z * z).sqrt()
            })
            .collect();
        let l = Lattice { n, values: &values };
        let tris = all(&l, 0.0);
        let (vol, open) = volume_and_open(&l, &tris, 0.0);
        assert_eq!(open, 0, "every edge is shared by two triangles wound oppositely");
        let exact = 4.0 / 3.0 * std::f64::consts::PI * (r as f64).powi(3);
        assert!((vol - exact).abs() < 0.02 * exact, "volume {vol} against {exact} (positive: outward normals)");
    }

    #[test]
    fn values_on_the_level_and_a_checkerboard_still_close() {
        // values exactly at the level (flat triangles) and alternating cells (every case at once)
        let n = 9;
        let values: Vec<f32> = (0..n * n * n)
            .map(|i| {
                let (x, y, z) = (i % n, i / n % n, i / (n * n));
                let border = x == 0 || y == 0 || z == 0 || x == n - 1 || y == n - 1 || z == n - 1;
                if border {
                    0.0
                } else {
                    [0.0, 1.0, 2.0][(x + 2 * y + z) % 3]
                }
            })
            .collect();
        let l = Lattice { n, values: &values };
        for level in [0.5, 1.0, 1.5] {
            let tris = all(&l, level);
            assert!(!tris.is_empty());
            let (vol, open) = volume_and_open(&l, &tris, level);
            assert_eq!(open, 0, "level {level}");
            assert!(vol > 0.0, "level {level}: volume {vol}");
        }
    }
}
