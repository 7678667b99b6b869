//! `nerf mesh` and the mesh module on a model whose density is known in
//! closed form: σ = b − k·(|x| + |y| + |z|), so the surface σ = τ is the
//! octahedron |x| + |y| + |z| = (b − τ)/k, of volume 4r³/3 and area 4√3·r².

mod support;

use nerf_infer::format::Scheme;
use nerf_infer::Orbit;
use nerf_infer::{Model, RenderOptions};
use nerf_train::eval::render_view;
use nerf_train::export::{quantise, random_model, OwnedModel};
use nerf_train::mesh::silhouette::{iou, silhouette};
use nerf_train::mesh::{extract, sample_density, write, Mesh, MeshOptions};
use support::cli::{fails, ok, s, tmp};
use support::{small_config, unit_scene};

const B: f32 = 7525.0;
const K: f32 = 10000.0;
const LEVEL: f32 = 25.0;
/// The octahedron's radius at `LEVEL`.
const R: f64 = ((B - LEVEL) / K) as f64;

fn put(bytes: &mut [u8], at: usize, v: f32) {
    bytes[4 * at..4 * at + 4].copy_from_slice(&v.to_le_bytes());
}

/// The trunk computes relu(±x), relu(±y), relu(±z) and carries them on;
/// the density head sums them. Layers beyond the density head keep their
/// random weights (the colour does not matter here).
fn octahedron() -> OwnedModel {
    let cfg = small_config();
    let mut m = random_model(&cfg, unit_scene(), 1, 1.0).unwrap();
    let depth = m.topology.depth as usize;
    let topo = m.topology;
    for net in std::iter::once(&mut m.coarse).chain(m.fine.as_mut()) {
        for (i, l) in net.layers.iter_mut().enumerate().take(depth + 1) {
            l.weights.fill(0);
            l.bias.fill(0);
            let od = l.out_dim as usize;
            if i == 0 {
                // inputs 0..3 are x, y, z (the encoding includes its input)
                for c in 0..3 {
                    put(&mut l.weights, c * od + 2 * c, 1.0);
                    put(&mut l.weights, c * od + 2 * c + 1, -1.0);
                }
                l.act_max = 1.0;
            } else if i < depth {
                // a skip layer reads the encoding first, then the previous layer
                let off = if topo.is_skip(i) { l.in_dim as usize - cfg.model.width as usize } else { 0 };
                for c in 0..6 {
                    put(&mut l.weights, (off + c) * od + c, 1.0);
                }
                l.act_max = 1.0;
            } else {
                for c in 0..6 {
                    put(&mut l.weights, c * od, -K);
                }
                put(&mut l.bias, 0, B);
                l.act_max = B;
            }
        }
    }
    m.grid = None;
    m
}

#[test]
fn the_surface_of_a_known_density_is_closed_and_of_its_volume_and_area() {
    let owned = octahedron();
    let bytes = owned.to_bytes().unwrap();
    let m = Model::from_bytes(&bytes).unwrap();
    let res = 64;
    let density = sample_density(&m, res, &|_| {});
    let mesh = extract(&m, &density, MeshOptions { resolution: res, threshold: LEVEL, colours: true }).unwrap();
    let st = mesh.stats();
    assert_eq!(st.open_edges, 0, "closed and consistently wound");
    let (vol, area) = (4.0 / 3.0 * R.powi(3), 4.0 * 3f64.sqrt() * R * R);
    assert!((st.volume - vol).abs() < 0.01 * vol, "volume {} against {vol}", st.volume);
    assert!((st.area - area).abs() < 0.02 * area, "area {} against {area}", st.area);
    assert_eq!(mesh.colours.len(), mesh.positions.len());
    // every vertex on the octahedron (to the lattice's interpolation)
    for p in &mesh.positions {
        let d = (p[0].abs() + p[1].abs() + p[2].abs()) as f64;
        assert!((d - R).abs() < 2.0 / res as f64, "vertex {p:?} off the surface: {d}");
    }
}

#[test]
fn quantised_models_mesh_through_the_fixed_point_network() {
    let owned = octahedron();
    let f32_bytes = owned.to_bytes().unwrap();
    let q = quantise(&Model::from_bytes(&f32_bytes).unwrap(), Scheme::I16).unwrap().to_bytes().unwrap();
    let m = Model::from_bytes(&q).unwrap();
    assert_eq!(m.scheme(), Scheme::I16);
    let density = sample_density(&m, 48, &|_| {});
    let mesh = extract(&m, &density, MeshOptions { resolution: 48, threshold: LEVEL, colours: true }).unwrap();
    let st = mesh.stats();
    let vol = 4.0 / 3.0 * R.powi(3);
    assert_eq!(st.open_edges, 0);
    assert!((st.volume - vol).abs() < 0.02 * vol, "volume {} against {vol}", st.volume);
}

#[test]
fn the_silhouette_matches_the_rendered_opacity() {
    let bytes = octahedron().to_bytes().unwrap();
    let m = Model::from_bytes(&bytes).unwrap();
    let density = sample_density(&m, 64, &|_| {});
    let mesh = extract(&m, &density, MeshOptions { resolution: 64, threshold: LEVEL, colours: false }).unwrap();
    for turn in [0.0, 0.3] {
        let cam = Orbit::new(&m.scene, None).camera(turn, 48, 48).unwrap();
        let opts = RenderOptions { coarse: 256, fine: 0, early_stop: 0.0, seed: None };
        let r = render_view(&m, opts, &cam).unwrap();
        let rendered: Vec<bool> = r.opacity.iter().map(|&a| a > 0.5).collect();
        let drawn = silhouette(&mesh, &cam);
        let covered = drawn.iter().filter(|&&c| c).count();
        assert!(covered > 200, "the octahedron fills a good part of the view: {covered} pixels");
        let v = iou(&drawn, &rendered);
        assert!(v > 0.95, "turn {turn}: IoU {v}");
    }
}

#[test]
fn mesh_files_hold_what_their_headers_say() {
    let bytes = octahedron().to_bytes().unwrap();
    let m = Model::from_bytes(&bytes).unwrap();
    let density = sample_density(&m, 16, &|_| {});
    let mesh = extract(&m, &density, MeshOptions { resolution: 16, threshold: LEVEL, colours: true }).unwrap();
    let (nv, nf) = (mesh.positions.len(), mesh.triangles.len());
    let ply = write::ply(&mesh);
    let end = b"end_header\n";
    let head_len = ply.windows(end.len()).position(|w| w == end).unwrap() + end.len();
    let head = std::str::from_utf8(&ply[..head_len]).unwrap();
    assert!(head.contains(&format!("element vertex {nv}\n")) && head.contains(&format!("element face {nf}\n")));
    assert_eq!(ply.len(), head_len + nv * (12 + 3) + nf * (1 + 12));
    let obj = String::from_utf8(write::obj(&mesh)).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), nv);
    assert_eq!(obj.lines().filter(|l| l.starts_with("f ")).count(), nf);
    let max_index = obj
        .lines()
        .filter(|l| l.starts_with("f "))
        .flat_map(|l| l[2..].split(' '))
        .map(|t| t.parse::<usize>().unwrap())
        .max();
    assert_eq!(max_index, Some(nv), "1-based indices up to the vertex count");
}

#[test]
fn the_command_writes_the_mesh_and_refuses_what_it_cannot_do() {
    let dir = tmp("mesh-cli");
    let model = dir.join("octahedron.nerf");
    std::fs::write(&model, octahedron().to_bytes().unwrap()).unwrap();
    let out = dir.join("o.ply");
    let report = ok(&["mesh", s(&model), "--out", s(&out), "--resolution", "32"]);
    let v: serde_json::Value = serde_json::from_str(&report).unwrap();
    assert_eq!(v["closed"], true, "{report}");
    assert!(std::fs::metadata(&out).unwrap().len() > 1000);
    let e = fails(&["mesh", s(&model), "--out", s(&dir.join("o.stl"))]);
    assert!(e.contains("--out") && e.contains(".ply or .obj"), "{e}");
    let e = fails(&["mesh", s(&model), "--out", s(&out), "--threshold=-1"]);
    assert!(e.contains("--threshold"), "{e}");
    // a threshold the density never reaches: no surface, no file, not a "closed" empty mesh
    let none = dir.join("none.ply");
    let e = fails(&["mesh", s(&model), "--out", s(&none), "--resolution", "32", "--threshold", "1e30"]);
    assert!(e.contains("no surface at --threshold") && e.contains("peaks at"), "{e}");
    assert!(!none.exists());
    let same = dir.join("model.ply");
    std::fs::copy(&model, &same).unwrap();
    let e = fails(&["mesh", s(&same), "--out", s(&same)]);
    assert!(e.contains("is the input file"), "{e}");
    let e = fails(&["mesh", s(&model), "--out", s(&out), "--resolution", "1"]);
    assert!(e.contains("--resolution"), "{e}");
}

/// A closed tetrahedron (4 triangles) and a closed octahedron (8), apart.
fn two_pieces() -> Mesh {
    let mut m = Mesh::default();
    let tet = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    m.positions.extend(tet.map(|p: [f32; 3]| [p[0] + 5.0, p[1], p[2]]));
    m.triangles.extend([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]);
    let o = 4;
    m.positions.extend([
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ]);
    for (a, b) in [(0, 2), (2, 1), (1, 3), (3, 0)] {
        m.triangles.push([o + a, o + b, o + 4]);
        m.triangles.push([o + b, o + a, o + 5]);
    }
    m.colours = (0..m.positions.len()).map(|i| [i as u8; 3]).collect();
    m
}

#[test]
fn small_pieces_are_dropped_whole() {
    let m = two_pieces();
    let st = m.stats();
    assert_eq!((st.triangles, st.open_edges), (12, 0));
    assert!((st.volume - (1.0 / 6.0 + 4.0 / 3.0)).abs() < 1e-6, "both outward: {}", st.volume);
    let mut keep = m.clone();
    assert_eq!(keep.drop_small_pieces(0.5), 0, "4 ≥ 0.5 · 8");
    assert_eq!(keep.triangles, m.triangles);
    let mut big = m.clone();
    assert_eq!(big.drop_small_pieces(0.6), 1, "4 < 0.6 · 8");
    let st = big.stats();
    assert_eq!((st.vertices, st.triangles, st.open_edges), (6, 8, 0));
    assert!((st.volume - 4.0 / 3.0).abs() < 1e-6);
    // the octahedron's vertices keep their colours
    let mut colours = big.colours.clone();
    colours.sort();
    assert_eq!(colours, (4..10).map(|i| [i as u8; 3]).collect::<Vec<_>>());
}
