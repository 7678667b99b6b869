//! Reading and writing COLMAP models: round trips, and damaged or hostile
//! files refused by name.

use super::*;

/// A fresh directory, removed with the guard.
fn tmp(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("nerf-colmap-io-{name}-")).tempdir().unwrap()
}

fn sample() -> Reconstruction {
    Reconstruction {
        cameras: vec![
            ColmapCamera {
                id: 1,
                model: CameraModel::SimplePinhole,
                width: 640,
                height: 480,
                params: vec![500.5, 320.0, 240.25],
            },
            ColmapCamera {
                id: 7,
                model: CameraModel::Opencv,
                width: 800,
                height: 600,
                params: vec![600.0, 601.0, 400.0, 300.0, 0.1, -0.02, 0.001, -0.0005],
            },
        ],
        images: vec![
            ColmapImage {
                id: 3,
                qvec: [0.9, 0.1, -0.3, 0.2],
                tvec: [1.0 / 3.0, -2.0, 5.5],
                camera_id: 1,
                name: "a b.jpg".into(),
            },
            ColmapImage {
                id: 4,
                qvec: [1.0, 0.0, 0.0, 0.0],
                tvec: [0.0, 0.0, 1e-17],
                camera_id: 7,
                name: "sub/c.png".into(),
            },
        ],
        points: vec![
            ColmapPoint { xyz: [0.1, 0.2, 0.3], rgb: [1, 2, 255], error: 0.75, track_len: 3 },
            ColmapPoint { xyz: [-1e3, 2.5, std::f64::consts::PI], rgb: [0, 0, 0], error: 0.0, track_len: 0 },
        ],
    }
}

#[test]
fn binary_and_text_round_trip_to_the_same_model() {
    let d_dir = tmp("round-trip");
    let d = d_dir.path();
    let (b, t) = (d.join("bin"), d.join("txt"));
    std::fs::create_dir_all(&b).unwrap();
    std::fs::create_dir_all(&t).unwrap();
    write_model_bin(&b, &sample()).unwrap();
    write_model_txt(&t, &sample()).unwrap();
    assert_eq!(read_model(&b).unwrap(), sample());
    assert_eq!(read_model(&t).unwrap(), sample());
}

#[test]
fn colmaps_text_layout_reads() {
    let d_dir = tmp("text");
    let d = d_dir.path();
    // comments after blanks too: COLMAP trims each line before it looks for `#`
    std::fs::write(d.join("cameras.txt"), "# Camera list\n  # Number of cameras: 1\n1 PINHOLE 100 80 90 91 50 40\n")
        .unwrap();
    std::fs::write(
        d.join("images.txt"),
        "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n\
         1 1 0 0 0 0 0 0 1 x.jpg\n10.5 20.5 -1 11 12 3\n\t# y next\n2 1 0 0 0 1 2 3 1 y.jpg\n\n3 1 0 0 0 0 0 1 1 z.jpg",
    )
    .unwrap();
    let r = read_model(d).unwrap();
    assert_eq!(r.cameras[0].params, vec![90.0, 91.0, 50.0, 40.0]);
    let names: Vec<&str> = r.images.iter().map(|i| i.name.as_str()).collect();
    assert_eq!(names, ["x.jpg", "y.jpg", "z.jpg"]);
    assert_eq!(r.images[1].tvec, [1.0, 2.0, 3.0]);
    assert!(r.points.is_empty());
}

#[test]
fn truncated_and_hostile_binary_files_are_errors() {
    let d_dir = tmp("hostile");
    let d = d_dir.path();
    write_model_bin(d, &sample()).unwrap();
    for (f, read) in [
        ("cameras.bin", (|p: &Path| read_cameras_bin(p).map(|_| ())) as fn(&Path) -> Result<(), ParseError>),
        ("images.bin", |p: &Path| read_images_bin(p).map(|_| ())),
        ("points3D.bin", |p: &Path| read_points_bin(p).map(|_| ())),
    ] {
        let full = std::fs::read(d.join(f)).unwrap();
        let cut = d.join(format!("cut-{f}"));
        for n in 0..full.len() {
            std::fs::write(&cut, &full[..n]).unwrap();
            assert!(read(&cut).is_err(), "{f} cut at {n} bytes");
        }
        let mut long = full.clone();
        long.push(0);
        std::fs::write(&cut, &long).unwrap();
        assert!(read(&cut).unwrap_err().msg.contains("unexpected bytes"));
    }
    // a huge count in a tiny file
    std::fs::write(d.join("huge.bin"), u64::MAX.to_le_bytes()).unwrap();
    assert!(read_points_bin(&d.join("huge.bin")).unwrap_err().msg.contains("does not fit"));
    // unknown model id and name
    let mut c = std::fs::read(d.join("cameras.bin")).unwrap();
    c[12..16].copy_from_slice(&99i32.to_le_bytes());
    std::fs::write(d.join("cameras.bin"), &c).unwrap();
    assert!(read_cameras_bin(&d.join("cameras.bin")).unwrap_err().msg.contains("unknown camera model id 99"));
    std::fs::write(d.join("cameras.txt"), "1 WEIRD 10 10 1 2 3\n").unwrap();
    assert!(read_cameras_txt(&d.join("cameras.txt")).unwrap_err().msg.contains("unknown camera model WEIRD"));
    // non-finite values and a camera the images do not know
    std::fs::write(d.join("cameras.txt"), "1 PINHOLE 10 10 NaN 2 3 4\n").unwrap();
    assert!(read_cameras_txt(&d.join("cameras.txt")).unwrap_err().msg.contains("non-finite"));
    let t_dir = tmp("orphan");
    let t = t_dir.path();
    let mut s = sample();
    s.images[0].camera_id = 9;
    write_model_txt(t, &s).unwrap();
    let e = read_model(t).unwrap_err();
    assert!(e.msg.contains("camera 9 is not in the cameras file") && e.msg.contains("a b.jpg"), "{e}");
}
