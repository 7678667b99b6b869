//! Loaders on the built-in scene written in both layouts, and the errors
//! that bad files give.

use nerf_train::dataset::synthetic::{write_blender, write_llff, SceneSpec};
use nerf_train::dataset::{load, Format, LoadOptions, Split};
use std::path::Path;

mod support;
use support::cli::tmp;

fn spec() -> SceneSpec {
    SceneSpec { size: 16, train: 6, val: 2, test: 2 }
}

fn opts(format: Format, downscale: u32) -> LoadOptions {
    LoadOptions { format, downscale, holdout: 4, ..LoadOptions::default() }
}

#[test]
fn blender_layout_round_trips_and_downscales() {
    let d = tmp("blender");
    write_blender(&d, spec()).unwrap();
    let train = load(&d, Split::Train, opts(Format::Auto, 1)).unwrap();
    assert_eq!(train.views.len(), 6);
    assert_eq!((train.views[0].camera.width, train.views[0].camera.height), (16, 16));
    assert!(train.scene.white_background && train.scene.near == 2.0 && train.scene.far == 6.0);
    // the object covers part of the image: some pixels are not white
    assert!(train.views[0].rgb.iter().any(|p| p[0] < 0.9));
    let half = load(&d, Split::Val, opts(Format::Blender, 2)).unwrap();
    assert_eq!((half.views[0].camera.width, half.views.len()), (8, 2));
    // area averaging: the downscaled pixel is the mean of its 2×2 block
    let full = load(&d, Split::Val, opts(Format::Blender, 1)).unwrap();
    let mean: f32 = [0, 1, 16, 17].iter().map(|&i| full.views[0].rgb[i][1]).sum::<f32>() / 4.0;
    assert!((half.views[0].rgb[0][1] - mean).abs() < 1e-6);
    // focal length scales with the image
    assert!((half.views[0].camera.fx * 2.0 - full.views[0].camera.fx).abs() < 1e-4);
}

#[test]
fn the_cells_photos_resolve_follow_their_pixel_footprint() {
    // the built-in scene: bounds ±1, cameras 4 from their centre, lego's field of view; two cells per
    // pixel footprint (4 / focal) over the bounds' 2 units is the focal length in pixels: 22.2 at
    // 16 pixels, 11.1 at 8, rounded up to a power of two
    let d = tmp("footprint");
    write_blender(&d, spec()).unwrap();
    let cells = |downscale| load(&d, Split::Train, opts(Format::Auto, downscale)).unwrap().resolvable_cells();
    assert_eq!((cells(1), cells(2)), (Some(32), Some(16)));
    // bounds that hold the cameras (cameras 4 from the centre): the centre is not what they look at
    let mut around = load(&d, Split::Train, opts(Format::Auto, 1)).unwrap();
    (around.scene.bounds_min, around.scene.bounds_max) = ([-5.0; 3], [5.0; 3]);
    assert_eq!(around.resolvable_cells(), None);
    (around.scene.bounds_min, around.scene.bounds_max) = ([-2.0; 3], [2.0; 3]);
    assert_eq!(around.resolvable_cells(), Some(64), "twice the side, twice the cells: 44.4");
    // forward-facing scenes live in NDC, where a world-space footprint says nothing
    write_llff(&d.join("llff"), spec()).unwrap();
    let llff = load(&d.join("llff"), Split::Train, opts(Format::Llff, 1)).unwrap();
    // forward-facing: two cells per pixel of the reference camera along the NDC box's x and y
    let (s, n) = (&llff.scene, llff.scene.ndc.unwrap());
    let cells = ((s.bounds_max[0] - s.bounds_min[0]) * n.width).max((s.bounds_max[1] - s.bounds_min[1]) * n.height);
    assert_eq!(llff.resolvable_cells(), Some((cells.ceil() as u32).next_power_of_two()));
}

#[test]
fn llff_layout_loads_in_ndc_with_holdout() {
    let d = tmp("llff");
    write_llff(&d, spec()).unwrap();
    let train = load(&d, Split::Train, opts(Format::Auto, 1)).unwrap();
    let test = load(&d, Split::Test, opts(Format::Llff, 1)).unwrap();
    assert_eq!(train.views.len() + test.views.len(), 8);
    assert_eq!(test.views.len(), 2); // images 0 and 4 with holdout 4
    assert!(train.scene.ndc.is_some() && train.scene.near == 0.0 && train.scene.far == 1.0);
    // every training ray enters the NDC volume
    let v = &train.views[0];
    let (o, dir) = v.camera.ray(8, 6);
    let r = nerf_infer::Ray::new(&train.scene, o, dir).unwrap();
    let p = r.at(0.5);
    assert!(p.abs().max_element() <= 1.01, "{p:?} (normalised to the box)");
}

/// The cameras of a forward-facing capture spread about their mean pose,
/// as LLFF's do, and NDC is built on that mean: a held-out camera away
/// from it sees the scene's box through every pixel, from the nearest
/// scene depth (NDC z −0.5) to infinity (t = 1), so no pixel renders the
/// background for want of a box (the black edge of a cut box).
#[test]
fn forward_facing_rays_of_every_camera_stay_in_the_box_from_the_nearest_depth_to_infinity() {
    let d = tmp("llff_spread");
    write_llff(&d, SceneSpec { size: 32, train: 18, val: 1, test: 1 }).unwrap();
    for split in [Split::Train, Split::Test] {
        let data = load(&d, split, opts(Format::Llff, 1)).unwrap();
        let (scene, n) = (&data.scene, data.scene.ndc.unwrap());
        for v in &data.views {
            let (w, h) = (v.camera.width, v.camera.height);
            for (x, y) in (0..h).flat_map(|y| (0..w).map(move |x| (x, y))) {
                let (o, dir) = v.camera.ray(x, y);
                let r = nerf_infer::Ray::new(scene, o, dir);
                let r = r.unwrap_or_else(|| panic!("{} pixel ({x}, {y}): the ray misses the box", v.name));
                let (o2, d2) = nerf_infer::camera::ndc_ray(n.width, n.height, n.focal, 1.0, o, dir).unwrap();
                let nearest = (-0.5 - o2.z) / d2.z;
                assert!(r.far >= 1.0 - 1e-6, "{} pixel ({x}, {y}): leaves the box at t = {}", v.name, r.far);
                assert!(r.near <= nearest + 1e-6, "{} pixel ({x}, {y}): enters at t = {} > {nearest}", v.name, r.near);
            }
        }
    }
}

/// A forward-facing capture whose photos resolve more cells than the
/// preset's grid has gets its grid sized to them with 16 levels (the
/// preset's 8 would be 2.2× apart); a user who names the levels keeps
/// theirs, and photos the preset's grid already resolves keep 8.
#[test]
fn a_forward_facing_grid_sized_to_large_photos_gets_sixteen_levels_unless_the_configuration_names_them() {
    use nerf_train::config::{Preset, TrainConfig};
    use nerf_train::run::{fit_to_data, Fit};
    let d = tmp("llff_levels");
    write_llff(&d, SceneSpec { size: 32, train: 6, val: 1, test: 1 }).unwrap();
    let small = load(&d, Split::Train, opts(Format::Llff, 1)).unwrap();
    let preset = Preset::default().config();
    let kept = fit_to_data(&preset, Fit::ALL, &small).unwrap().cfg;
    assert_eq!((kept.features.levels, kept.features.max_res), (preset.features.levels, preset.features.max_res));
    // the same capture as 1008×756 photos would see it
    let mut large = small.clone();
    let n = large.scene.ndc.as_mut().unwrap();
    (n.width, n.height) = (1008.0, 756.0);
    let fitted = fit_to_data(&preset, Fit::ALL, &large).unwrap();
    let f = &fitted.cfg.features;
    assert_eq!((f.levels, f.max_res, f.log2_table), (Some(TrainConfig::SIZED_LEVELS), 4096, 19));
    assert!(fitted.notes[0].contains("16 levels (was 8"), "{:?}", fitted.notes);
    let over = serde_json::json!({"features": {"levels": 12}});
    let named = fit_to_data(
        &preset.clone().with(|c| c.features.levels = std::num::NonZeroU8::new(12)),
        Fit::unless_named(&over),
        &large,
    );
    assert_eq!(named.unwrap().cfg.features.levels.map(|l| l.get()), Some(12));
}

/// An object scene whose photos resolve 2 048 cells or more gets its grid
/// sized with 16 levels (the preset's 8 from 16 cells would be 2× apart or
/// more, as lego's at 800×800); one sized to 512 cells keeps 8.
#[test]
fn an_object_grid_sized_to_large_photos_gets_sixteen_levels_where_eight_would_be_twice_apart() {
    use nerf_train::config::{Preset, TrainConfig};
    use nerf_train::run::{fit_to_data, Fit};
    let d = tmp("object_levels");
    write_blender(&d, spec()).unwrap();
    let preset = Preset::default().config();
    // the built-in scene resolves as many cells as its focal length in pixels (bounds ±1, cameras 4 away)
    let fitted = |focal: f32| {
        let mut data = load(&d, Split::Train, opts(Format::Blender, 1)).unwrap();
        data.views.iter_mut().for_each(|v| (v.camera.fx, v.camera.fy) = (focal, focal));
        fit_to_data(&preset, Fit::ALL, &data).unwrap().cfg.features
    };
    let mid = fitted(400.0);
    assert_eq!((mid.levels, mid.max_res), (preset.features.levels, 512));
    let large = fitted(1500.0);
    assert_eq!((large.levels, large.max_res, large.log2_table), (Some(TrainConfig::SIZED_LEVELS), 2048, 18));
}

#[test]
fn ngp_layout_with_intrinsics() {
    let d = tmp("ngp");
    write_blender(&d, spec()).unwrap();
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("transforms_train.json")).unwrap()).unwrap();
    let mut frames = t["frames"].clone();
    for f in frames.as_array_mut().unwrap() {
        let p = f["file_path"].as_str().unwrap().to_string() + ".png";
        f["file_path"] = p.into();
    }
    let fl = 8.0 / (0.691_111_2f64 / 2.0).tan();
    let ngp = serde_json::json!({ "fl_x": fl, "fl_y": fl, "cx": 8.0, "cy": 8.0, "w": 16, "h": 16, "frames": frames });
    std::fs::remove_file(d.join("transforms_train.json")).unwrap();
    std::fs::write(d.join("transforms.json"), ngp.to_string()).unwrap();
    let train = load(&d, Split::Train, opts(Format::Auto, 1)).unwrap();
    let val = load(&d, Split::Val, opts(Format::Ngp, 1)).unwrap(); // transforms_val.json exists: used
    assert_eq!(train.views.len(), 4); // 6 frames, holdout 4 → frames 0 and 4 held out
    assert_eq!(val.views.len(), 2);
    assert!((train.views[0].camera.fx - fl as f32).abs() < 1e-3);
}

fn err(d: &Path, split: Split) -> String {
    load(d, split, opts(Format::Auto, 1)).unwrap_err().to_string()
}

#[test]
fn bad_files_give_one_line_errors_naming_the_file() {
    let d = tmp("bad");
    assert!(err(&d.join("missing"), Split::Train).contains("missing: no such directory"));
    write_blender(&d, spec()).unwrap();
    // corrupt PNG
    std::fs::write(d.join("train/r_1.png"), b"not a png").unwrap();
    let e = err(&d, Split::Train);
    assert!(e.contains("r_1.png") && e.contains("cannot read image"), "{e}");
    // images of different sizes
    image::RgbaImage::new(8, 8).save(d.join("train/r_1.png")).unwrap();
    let e = err(&d, Split::Train);
    assert!(e.contains("r_1.png") && e.contains("differs"), "{e}");
    // malformed JSON
    std::fs::write(d.join("transforms_val.json"), "{ \"frames\": [ ").unwrap();
    let e = err(&d, Split::Val);
    assert!(e.contains("transforms_val.json") && e.contains("malformed JSON"), "{e}");
    // a pose that is not rigid
    let t = std::fs::read_to_string(d.join("transforms_test.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&t).unwrap();
    v["frames"][0]["transform_matrix"][0][0] = 3.0.into();
    std::fs::write(d.join("transforms_test.json"), v.to_string()).unwrap();
    let e = err(&d, Split::Test);
    assert!(e.contains("transforms_test.json") && e.contains("not a rigid transform"), "{e}");
    for e in [err(&d, Split::Train), err(&d, Split::Val), err(&d, Split::Test)] {
        assert!(!e.contains('\n'), "multi-line error: {e}");
    }
    // malformed NPY
    let l = tmp("badnpy");
    write_llff(&l, spec()).unwrap();
    std::fs::write(l.join("poses_bounds.npy"), b"\x93NUMPY\x01\x00\x10\x00{'descr': '<i4'}").unwrap();
    let e = load(&l, Split::Train, opts(Format::Auto, 1)).unwrap_err().to_string();
    assert!(e.contains("poses_bounds.npy") && e.contains("malformed NPY"), "{e}");
}
