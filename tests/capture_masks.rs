//! Masks of real captures on data the tests make: nerfstudio's
//! `mask_path`, COLMAP's and nerfstudio's masks folders, at every
//! downscale.

mod support;

use nerf_train::dataset::synthetic::{write_colmap, ColmapText};
use nerf_train::dataset::{load, Format, LoadOptions, Split};
use support::captures::*;
use support::cli::tmp;

#[test]
fn nerfstudio_masks_leave_their_pixels_out_at_every_downscale() {
    let d = tmp("ngp-masks");
    ngp_capture(&d);
    // frames img_000, img_001, img_003 (two images missing); every 4th held out: img_000 is the test view
    std::fs::create_dir_all(d.join("masks")).unwrap();
    // the five left columns left out (0), the rest kept (any other value)
    let mask = image::GrayImage::from_fn(16, 16, |x, _| image::Luma([if x < 5 { 0 } else { 1 + x as u8 }]));
    mask.save(d.join("masks/img_000.png")).unwrap();
    edit_transforms(&d, |v| v["frames"][0]["mask_path"] = "masks/img_000.png".into());
    let full = load(&d, Split::Test, opts(Format::Auto)).unwrap();
    let m = &full.views[0].mask;
    assert_eq!(m.len(), 256);
    assert!(m.iter().enumerate().all(|(i, &k)| k == (i % 16 >= 5)));
    // at half size a pixel is kept only if all four photo pixels it averages are: columns 3.. (2 holds column 4)
    let half = load(&d, Split::Test, LoadOptions { downscale: 2, ..opts(Format::Auto) }).unwrap();
    assert!(half.views[0].mask.iter().enumerate().all(|(i, &k)| k == (i % 8 >= 3)));
    // resampled through the lens, the left-out columns stay out, the far side stays in
    let flat = load(&d, Split::Test, LoadOptions { undistort: true, ..opts(Format::Auto) }).unwrap();
    let m = &flat.views[0].mask;
    assert!(m.iter().enumerate().all(|(i, &k)| (i % 16 > 3 || !k) && (i % 16 < 8 || k)));
    // a resampled pixel is kept exactly when the lens imaged it (its source lies in the photo) and every
    // photo pixel it blends (weight above 10⁻⁴) is kept
    let (lens, c) = (full.views[0].lens, full.views[0].camera);
    let mut unimaged = 0;
    for (i, &k) in m.iter().enumerate() {
        let (x, y) = ((i % 16) as f64 + 0.5 - c.cx as f64, (i / 16) as f64 + 0.5 - c.cy as f64);
        let (xd, yd) = lens.distort(x / c.fx as f64, y / c.fy as f64);
        let (sx, sy) = (xd * c.fx as f64 + c.cx as f64, yd * c.fy as f64 + c.cy as f64);
        let imaged = (0.0..=16.0).contains(&sx) && (0.0..=16.0).contains(&sy);
        unimaged += !imaged as usize;
        let su = (sx - 0.5).clamp(0.0, 15.0);
        let (u0, a) = (su.floor() as usize, su.fract());
        let blended = [(u0, 1.0 - a), ((u0 + 1).min(15), a)];
        let kept = imaged && blended.iter().all(|&(u, w)| w < 1e-4 || u >= 5);
        assert_eq!(k, kept, "pixel {i}: source ({sx}, {sy})");
    }
    assert_eq!(unimaged, 0, "this lens images every pixel of the pinhole photo");
    // a pincushion lens leaves the pinhole photo's corners unimaged: they train on no photo's pixels
    let orig = std::fs::read_to_string(d.join("transforms.json")).unwrap();
    edit_transforms(&d, |v| v["k1"] = 0.4.into());
    let pin = load(&d, Split::Train, LoadOptions { undistort: true, ..opts(Format::Auto) }).unwrap();
    for v in &pin.views {
        assert!(!v.mask[0] && !v.mask[255] && v.mask[8 * 16 + 8], "{}", v.name);
    }
    std::fs::write(d.join("transforms.json"), orig).unwrap();
    // a held-out photo whose mask hides it whole is left out, and the split says so
    image::GrayImage::new(16, 16).save(d.join("masks/img_000.png")).unwrap();
    let e = load(&d, Split::Test, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("no images in the test split") && e.contains("all 1 of its photos hidden whole"), "{e}");
    // split files with Blender's camera_angle_x and masks load with their masks
    let mut t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("transforms.json")).unwrap()).unwrap();
    for k in ["k1", "k2", "p1", "p2"] {
        t[k] = 0.0.into();
    }
    t["camera_angle_x"] = 0.69.into();
    // the frames whose photo is there (the Blender loader reads every frame it lists)
    let there: Vec<serde_json::Value> = t["frames"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| d.join(f["file_path"].as_str().unwrap()).is_file())
        .cloned()
        .collect();
    t["frames"] = there.into();
    mask.save(d.join("masks/img_000.png")).unwrap();
    std::fs::write(d.join("transforms_train.json"), t.to_string()).unwrap();
    assert_eq!(nerf_train::dataset::detect(&d).unwrap(), Format::Ngp);
    let split = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert_eq!(split.views.iter().filter(|v| !v.mask.is_empty()).count(), 1);
    let e = load(&d, Split::Train, opts(Format::Blender)).unwrap();
    assert!(e.notes.iter().any(|n| n.contains("the Blender loader does not apply")), "{:?}", e.notes);
    std::fs::remove_file(d.join("transforms_train.json")).unwrap();
    // the training views have no mask: every pixel kept
    let train = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert!(train.views.iter().all(|v| v.mask.is_empty()));
    // a mask of another size, or one that is not there, is an error naming it
    image::GrayImage::new(8, 16).save(d.join("masks/img_000.png")).unwrap();
    let e = load(&d, Split::Test, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("img_000.png") && e.contains("mask is 8x16 but its photo") && e.contains("is 16x16"), "{e}");
    std::fs::remove_file(d.join("masks/img_000.png")).unwrap();
    let e = load(&d, Split::Test, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("mask_path") && e.contains("img_000.png") && e.contains("not a file"), "{e}");
}

#[test]
fn colmap_captures_take_masks_from_a_masks_folder_named_as_colmap_or_nerfstudio_names_them() {
    let d = tmp("colmap-masks");
    write_colmap(&d, spec(), ColmapText::Binary, false).unwrap();
    std::fs::create_dir_all(d.join("masks")).unwrap();
    let top = |size: u32| image::GrayImage::from_fn(size, size, |_, y| image::Luma([if y < 4 { 0 } else { 255 }]));
    // COLMAP's naming (the image's name with .png added), then nerfstudio's (the extension replaced)
    top(16).save(d.join("masks/img_002.jpg.png")).unwrap();
    top(16).save(d.join("masks/img_006.png")).unwrap();
    let data = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    for v in &data.views {
        let masked = v.name == "img_002" || v.name == "img_006";
        let expect: Vec<bool> = if masked { (0..256).map(|i| i / 16 >= 4).collect() } else { Vec::new() };
        assert_eq!(v.mask, expect, "{}", v.name);
    }
    assert!(data.notes.iter().any(|n| n.contains("2 of the 10 registered photos have a mask")), "{:?}", data.notes);
    // a mask of another size is an error naming it
    top(8).save(d.join("masks/img_006.png")).unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("img_006.png") && e.contains("mask is 8x8 but its photo") && e.contains("is 16x16"), "{e}");
    // a masks/ folder none of whose files is named as a photo's mask is reported
    std::fs::remove_file(d.join("masks/img_006.png")).unwrap();
    std::fs::rename(d.join("masks/img_002.jpg.png"), d.join("masks/img_002_mask.png")).unwrap();
    let data = load(&d, Split::Train, opts(Format::Auto)).unwrap();
    assert!(data.notes.iter().any(|n| n.contains("no masks applied")), "{:?}", data.notes);
    assert!(data.views.iter().all(|v| v.mask.is_empty()));
    // a photo with a mask under both names, and a masks that is a file: refused, not chosen between
    top(16).save(d.join("masks/img_004.jpg.png")).unwrap();
    top(16).save(d.join("masks/img_004.png")).unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("two masks for photo img_004.jpg: img_004.jpg.png and img_004.png"), "{e}");
    std::fs::remove_dir_all(d.join("masks")).unwrap();
    std::fs::write(d.join("masks"), b"").unwrap();
    let e = load(&d, Split::Train, opts(Format::Auto)).unwrap_err().to_string();
    assert!(e.contains("masks") && e.contains("is not a folder"), "{e}");
}
