//! Round trips of the model format: versions written as the oldest that
//! holds the model, and invalid fields refused.

use super::*;

#[test]
fn crc32_matches_zlib() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc32(b""), 0);
}

#[test]
fn header_errors_are_typed() {
    assert_eq!(Model::from_bytes(b"NE").unwrap_err(), Error::Truncated);
    assert_eq!(Model::from_bytes(b"XXXXXXXXXXXXXXXXXX").unwrap_err(), Error::BadMagic);
    let mut h = [0u8; 14];
    h[..4].copy_from_slice(&MAGIC);
    let newer = FORMAT_VERSION + 1;
    h[4..6].copy_from_slice(&newer.to_le_bytes());
    assert_eq!(Model::from_bytes(&h).unwrap_err(), Error::UnsupportedVersion(newer));
}

/// A frame under another magic (a checkpoint's) reads back as written,
/// and each damage is named in the documented order.
#[cfg(feature = "alloc")]
#[test]
fn frames_round_trip_and_name_their_damage() {
    let magic = b"TESTMAGC";
    let f = frame(magic, 7, b"payload").unwrap();
    assert_eq!(f.len(), magic.len() + FRAME_FIELDS_LEN + 7);
    assert_eq!(unframe(&f, magic, 7, 7).unwrap(), (7, &b"payload"[..]));
    assert_eq!(unframe(&f[..5], magic, 7, 7), Err(Error::Truncated));
    assert_eq!(unframe(&f[..12], magic, 7, 7), Err(Error::Truncated));
    assert_eq!(unframe(&f, b"OTHERMAG", 7, 7), Err(Error::BadMagic));
    assert_eq!(unframe(&f, magic, 8, 9), Err(Error::UnsupportedVersion(7)));
    assert_eq!(unframe(&f[..f.len() - 1], magic, 7, 7), Err(Error::Truncated));
    let mut long = f.clone();
    long.push(0);
    assert_eq!(unframe(&long, magic, 7, 7), Err(Error::TrailingBytes));
    let mut flipped = f.clone();
    *flipped.last_mut().unwrap() ^= 1;
    assert_eq!(unframe(&flipped, magic, 7, 7), Err(Error::ChecksumMismatch));
    // a model file is the same frame under MAGIC
    let golden = include_bytes!("../../tests/data/golden.nerf");
    let (version, payload) = unframe(golden, &MAGIC, FORMAT_VERSION_NO_GRID, FORMAT_VERSION).unwrap();
    assert_eq!(frame(&MAGIC, version, payload).unwrap(), golden);
}

/// A capture record makes a version-4 file that decodes to the same
/// model; without one the file is the version it was before, and an
/// invalid record is refused.
#[cfg(feature = "alloc")]
#[test]
fn capture_record_is_version_4() {
    let golden = include_bytes!("../../tests/data/golden.nerf");
    let mut m = Model::from_bytes(golden).unwrap();
    assert_eq!(to_bytes(&m).unwrap(), golden);
    let c = Capture { holdout: 8, views: 71, held_out_crc: 0xdead_beef, framing: Framing::Unbounded, lens: true };
    m.capture = Some(c);
    let bytes = to_bytes(&m).unwrap();
    assert_eq!(u16::from_le_bytes([bytes[4], bytes[5]]), 4);
    assert_eq!(Model::from_bytes(&bytes).unwrap(), m);
    m.capture = Some(Capture { holdout: 0, ..c });
    assert!(matches!(Model::from_bytes(&encode(&m).unwrap()), Err(Error::InvalidScene(_))));
}

/// A fitted orbit makes a version-9 file that decodes to the same model;
/// a version-8 file without one re-encodes byte for byte; an orbit out
/// of range, or in a forward-facing scene, is refused.
#[cfg(feature = "alloc")]
#[test]
fn a_fitted_orbit_is_version_9_and_checked() {
    let golden = include_bytes!("../../tests/data/golden8_density.nerf");
    let mut m = Model::from_bytes(golden).unwrap();
    assert_eq!(m.format_version(), FORMAT_VERSION_NO_ORBIT);
    assert_eq!(to_bytes(&m).unwrap(), golden);
    let o = FittedOrbit {
        centre: [0.1, -0.2, 0.3],
        up: [0.0, 0.6, 0.8],
        radius: 1.5,
        height: 0.4,
        fov_x: 0.9,
        azimuth: -2.0,
    };
    m.orbit = Some(o);
    let bytes = to_bytes(&m).unwrap();
    assert_eq!(u16::from_le_bytes([bytes[4], bytes[5]]), 9);
    assert_eq!(bytes.len(), golden.len() + 1 + 10 * 4, "one tag byte and ten f32");
    assert_eq!(Model::from_bytes(&bytes).unwrap(), m);
    let refused = |o: FittedOrbit| {
        let bad = Model { orbit: Some(o), ..m.clone() };
        matches!(Model::from_bytes(&encode(&bad).unwrap()), Err(Error::InvalidScene(_)))
    };
    assert!(refused(FittedOrbit { up: [0.0, 0.0, 2.0], ..o }));
    assert!(refused(FittedOrbit { radius: 0.0, ..o }));
    assert!(refused(FittedOrbit { height: 151.0, ..o }));
    assert!(refused(FittedOrbit { fov_x: 3.2, ..o }));
    assert!(refused(FittedOrbit { centre: [f32::NAN, 0.0, 0.0], ..o }));
    assert!(refused(FittedOrbit { azimuth: 3.2, ..o }));
    let mut ndc = m.clone();
    ndc.scene.ndc = Some(Ndc { focal: 50.0, width: 64.0, height: 48.0 });
    assert!(matches!(ndc.validate(), Err(Error::InvalidScene(s)) if s.contains("NDC")));
}

/// 16-bit parts make a version-6 file that re-encodes byte for byte;
/// parts of the wrong shape, in an f32 model, or differing between the
/// model and its networks are refused.
#[cfg(feature = "alloc")]
#[test]
fn precise_parts_are_version_6_and_checked() {
    let blob = include_bytes!("../../tests/data/golden8_precise.nerf");
    let m = Model::from_bytes(blob).unwrap();
    assert_eq!(m.format_version(), 6);
    assert_eq!(to_bytes(&m).unwrap(), blob);
    let p = m.precise.unwrap();
    assert_eq!(m.coarse.precise, Some(p.coarse));
    assert!(!p.coarse.view_dirs.is_empty() && p.coarse.colour.is_some());
    let refused = |m: &Model<'_>| Model::from_bytes(&encode(m).unwrap()).unwrap_err();
    // direction rows one element short
    let short = &p.coarse.view_dirs[..p.coarse.view_dirs.len() - 2];
    let mut bad = m.clone();
    bad.precise = Some(Precise { coarse: PreciseNet { view_dirs: short, ..p.coarse }, ..p });
    assert!(matches!(refused(&bad), Error::TensorLength(_)));
    // a colour head of the wrong width
    let mut narrow = p.coarse.colour.unwrap();
    narrow.in_dim -= 1;
    bad.precise = Some(Precise { coarse: PreciseNet { colour: Some(narrow), ..p.coarse }, ..p });
    assert!(matches!(refused(&bad), Error::LayerShape(_)));
    // a fine network's parts missing
    bad.precise = Some(Precise { fine: None, ..p });
    assert!(matches!(refused(&bad), Error::InvalidTopology(_)));
    // an f32 model
    let mut f = m.clone();
    f.coarse.scheme = Scheme::F32;
    assert!(matches!(f.validate(), Err(Error::InvalidTopology(s)) if s.contains("f32")));
}

/// A 16-bit density head makes a version-8 file that re-encodes byte
/// for byte and reads back into the networks; a head of the wrong
/// shape or length, one without the other 16-bit parts, or one that
/// differs from the networks' is refused.
#[cfg(feature = "alloc")]
#[test]
fn a_16_bit_density_head_is_version_8_and_checked() {
    let blob = include_bytes!("../../tests/data/golden8_density.nerf");
    let m = Model::from_bytes(blob).unwrap();
    assert_eq!(m.format_version(), 8);
    assert_eq!(to_bytes(&m).unwrap(), blob);
    let d = m.precise_density.unwrap();
    assert_eq!(m.coarse.precise.and_then(|p| p.density), Some(d.coarse));
    assert_eq!((d.coarse.out_dim, d.coarse.in_dim), (1, m.coarse.layers[sigma_layer(&m.topology)].in_dim));
    assert_eq!(m.fine.as_ref().and_then(|f| f.precise?.density), d.fine);
    let refused = |m: &Model<'_>| Model::from_bytes(&encode(m).unwrap()).unwrap_err();
    fn with<'a>(m: &Model<'a>, coarse: Layer<'a>) -> Model<'a> {
        let mut bad = m.clone();
        let (d, p) = (m.precise_density.unwrap(), m.precise.unwrap());
        bad.precise_density = Some(PreciseDensity { coarse, ..d });
        bad.precise = Some(Precise { coarse: PreciseNet { density: Some(coarse), ..p.coarse }, ..p });
        bad
    }
    // one weight short, one input too many
    let short = Layer { weights: &d.coarse.weights[..d.coarse.weights.len() - 2], ..d.coarse };
    assert!(matches!(refused(&with(&m, short)), Error::TensorLength(_)));
    let wide = Layer { in_dim: d.coarse.in_dim + 1, ..d.coarse };
    assert!(matches!(refused(&with(&m, wide)), Error::LayerShape(_)));
    // without the other 16-bit parts
    let mut bad = m.clone();
    bad.precise = None;
    assert!(matches!(refused(&bad), Error::InvalidTopology(_)));
    // the record and the networks disagree
    let mut bad = m.clone();
    bad.precise_density = None;
    assert!(matches!(bad.validate(), Err(Error::InvalidTopology(_))));
    // a crafted file with too few layers is refused, not read past its end
    let mut bad = m.clone();
    bad.coarse.layers.truncate(1);
    assert!(Model::from_bytes(&encode(&bad).unwrap()).is_err());
    // the version-7 reader's view of it: older files still read
    let old = Model::from_bytes(include_bytes!("../../tests/data/golden8_precise.nerf")).unwrap();
    assert!(old.precise_density.is_none() && old.coarse.precise.unwrap().density.is_none());
}

/// Without the `feature-grid` feature a model with a feature grid is
/// refused before anything else is checked; with it, this one (whose
/// layer 0 lacks the grid's inputs) fails on that instead.
#[cfg(feature = "alloc")]
#[test]
fn feature_grid_models_need_the_feature() {
    let table = [0u8; 8 * 2 * 2]; // 1 cell: 8 vertices of 2 i16
    let mut m = Model::from_bytes(include_bytes!("../../tests/data/golden.nerf")).unwrap();
    let resolutions = heapless::Vec::from_slice(&[1]).unwrap();
    m.features = Some(FeatureGrid { width: 2, log2_table: 3, frac_bits: 8, resolutions, table: &table, narrow: None });
    let e = Model::from_bytes(&encode(&m).unwrap()).unwrap_err();
    if cfg!(feature = "feature-grid") {
        assert_eq!(e, Error::LayerShape(0));
    } else {
        assert!(matches!(e, Error::Capacity(s) if s.contains("feature-grid")), "{e:?}");
    }
}

/// A narrow feature table makes a version-7 model. Files whose table,
/// codebook or bits disagree, with codes but no grid, or with codes in
/// an f32 model are refused with `InvalidEncoding` (a valid one round
/// trips in `nerf-train/tests/features.rs`).
#[cfg(feature = "alloc")]
#[test]
fn narrow_tables_are_version_7_and_checked() {
    let table = [0u8; 8 * 2 / 2]; // 1 cell: 8 vertices of 2 4-bit indices
    let codebook = [0u8; 16 * 2];
    let narrow = NarrowTable { bits: 4, codebook: &codebook };
    let mut m = Model::from_bytes(include_bytes!("../../tests/data/golden8.nerf")).unwrap();
    let resolutions = heapless::Vec::from_slice(&[1]).unwrap();
    let grid = FeatureGrid { width: 2, log2_table: 3, frac_bits: 8, resolutions, table: &table, narrow: Some(narrow) };
    m.features = Some(grid.clone());
    m.narrow = Some(narrow);
    assert_eq!(m.format_version(), 7);
    let decoded = |m: &Model<'_>| Model::from_bytes(&encode(m).unwrap()).map(|_| ());
    // consistent: the checks pass the table and fail later on layer 0's missing grid inputs
    if !cfg!(feature = "feature-grid") {
        return;
    }
    assert_eq!(decoded(&m), Err(Error::LayerShape(0)));
    let invalid = |m: &Model<'_>| matches!(decoded(m), Err(Error::InvalidEncoding(_)));
    for bits in [0, 5, 8, 16, 255] {
        let other = NarrowTable { bits, ..narrow };
        let bad = Model {
            narrow: Some(other),
            features: Some(FeatureGrid { narrow: Some(other), ..grid.clone() }),
            ..m.clone()
        };
        assert!(invalid(&bad), "{bits} bits");
    }
    let short = NarrowTable { codebook: &codebook[2..], ..narrow };
    let bad =
        Model { narrow: Some(short), features: Some(FeatureGrid { narrow: Some(short), ..grid.clone() }), ..m.clone() };
    assert!(invalid(&bad));
    let bad = Model { features: Some(FeatureGrid { table: &table[1..], ..grid.clone() }), ..m.clone() };
    assert!(invalid(&bad));
    let bad = Model { features: None, ..m.clone() };
    assert!(invalid(&bad));
    let mut f = m.clone();
    f.coarse.scheme = Scheme::F32;
    assert!(matches!(f.validate(), Err(Error::InvalidEncoding(s)) if s.contains("f32")));
}
