//! The entry points given NaN, infinities, empty and reversed ranges: the
//! encoding's and the samplers' give finite, in range and sorted outputs;
//! scenes, cameras, rays, render options and a model on the wrong numeric
//! path are refused with typed errors.

use glam::Vec3;
use nerf_infer::composite::alpha_f32;
use nerf_infer::fixed::to_fixed;
use nerf_infer::format::Scheme;
use nerf_infer::{AnyRenderer, Camera, Error, Model, Ray, RenderOptions, RendererF32, RendererFixed};

/// The golden f32 model and its int16 export (`tests/data/`).
const F32: &[u8] = include_bytes!("data/golden_f32.nerf");
const I16: &[u8] = include_bytes!("data/golden.nerf");

#[test]
fn encoding_entry_points_take_nan_and_infinity() {
    use nerf_infer::encoding::{encode_f32, sincospi_f32};
    for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(sincospi_f32(x), (0.0, 1.0));
        let mut out = [7.0f32; 3 * 33];
        let n = encode_f32([x, 0.5, x], 16, true, &mut out);
        assert!(out[..n].iter().all(|v| v.is_finite() && v.abs() <= 1.0), "{x}: {:?}", &out[..n]);
    }
    // the highest frequency at the edges of the coordinate range: sin(2^15 π p)
    // for p = ±1 is exactly 0, cos exactly 1
    let mut out = [0.0f32; 3 * 33];
    encode_f32([1.0, -1.0, 1.0 - f32::EPSILON], 16, true, &mut out);
    assert!(out.iter().all(|v| v.abs() <= 1.0));
    assert_eq!(sincospi_f32(32768.0), (0.0, 1.0));
    assert_eq!(sincospi_f32(-32768.0), (0.0, 1.0));
}

#[test]
fn sampling_entry_points_take_nan_and_infinity() {
    use nerf_infer::sampling::stratified_fixed;
    use nerf_infer::sampling::{sample_pdf_f32, stratified_f32};
    for n in [0, 1, 2, 8] {
        let mut t = vec![0.0f32; n];
        let mut tq = vec![0i32; n];
        for (near, far) in [(f32::NAN, 6.0), (2.0, f32::INFINITY), (2.0, 2.0), (6.0, 2.0), (2.0, 6.0)] {
            for jitter in [None, Some(9)] {
                stratified_f32(near, far, jitter, &mut t);
                let ok = t.iter().all(|v| v.is_finite()) && t.windows(2).all(|p| p[0] <= p[1]);
                assert!(ok, "{n} samples over {near}..{far}, jitter {jitter:?}: {t:?}");
                stratified_fixed(to_fixed(near, 16), to_fixed(far, 16), jitter, &mut tq);
                assert!(tq.windows(2).all(|p| p[0] <= p[1]), "{n} over {near}..{far} (Q16): {tq:?}");
            }
        }
    }
    let tc = [2.0, 2.5, 3.0, 3.5, 4.0];
    let mut cdf = [0.0f32; 5];
    let mut out = [0.0f32; 16];
    for w in [[f32::NAN; 5], [f32::INFINITY; 5], [0.0; 5], [-1.0, 1e30, f32::NAN, 0.0, f32::MAX]] {
        sample_pdf_f32(&tc, &w, |j| j as f32 / 15.0, &mut cdf, &mut out);
        assert!(out.iter().all(|v| (2.0..=4.0).contains(v)), "weights {w:?}: {out:?}");
        assert!(out.windows(2).all(|p| p[0] <= p[1]), "weights {w:?}: not sorted: {out:?}");
    }
}

#[test]
fn scene_and_camera_extremes_are_typed_errors() {
    #[cfg(feature = "alloc")]
    {
        let m = nerf_infer::format::owned::OwnedModel::from_model(&Model::from_bytes(F32).unwrap());
        for (near, far) in [(2.0, 2.0), (3.0, 2.0), (f32::NAN, 6.0), (2.0, f32::INFINITY), (-1.0, 6.0), (0.0, 30001.0)]
        {
            let mut bad = m.clone();
            bad.scene.near = near;
            bad.scene.far = far;
            let err = bad.to_bytes().and_then(|b| Model::from_bytes(&b).map(|_| ()));
            assert!(matches!(err, Err(Error::InvalidScene(_))), "near {near}, far {far}: {err:?}");
        }
    }
    let pose = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 4.0]];
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -1.0] {
        assert_eq!(Camera::new(8, 8, v, 4.0, 4.0, 4.0, pose).unwrap_err(), Error::InvalidCamera, "fx {v}");
        assert_eq!(Camera::new(8, 8, 4.0, 4.0, v, 4.0, pose).is_err(), !v.is_finite(), "cx {v}");
        let mut p = pose;
        p[1][2] = v;
        if v != 0.0 {
            assert_eq!(Camera::new(8, 8, 4.0, 4.0, 4.0, 4.0, p).unwrap_err(), Error::InvalidCamera, "pose {v}");
        }
        let mut p = pose;
        p[2][3] = v;
        let cam = Camera::new(8, 8, 4.0, 4.0, 4.0, 4.0, p);
        assert_eq!(cam.is_err(), !v.is_finite(), "position {v}");
    }
    for fov in [f32::NAN, f32::INFINITY, 0.0, core::f32::consts::PI, -0.5] {
        assert_eq!(Camera::from_fov(8, 8, fov, pose).unwrap_err(), Error::InvalidCamera, "fov {fov}");
    }
    assert_eq!(Camera::from_fov(0, 8, 0.7, pose).unwrap_err(), Error::InvalidCamera);
    // rays that are not finite or degenerate are refused before sampling
    let s = Model::from_bytes(F32).unwrap().scene;
    for (o, d) in [(Vec3::NAN, Vec3::X), (Vec3::ZERO, Vec3::ZERO), (Vec3::ZERO, Vec3::INFINITY)] {
        assert!(Ray::new(&s, o, d).is_none());
    }
}

#[test]
fn the_remaining_entry_points_take_nan_and_infinity() {
    use nerf_infer::camera::{is_rotation, ndc_ray};
    use nerf_infer::fixed::Requant;
    use nerf_infer::network::{BlockF32, F32 as F32Path};
    for v in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        assert_eq!(to_fixed(f32::NAN, 16), 0);
        assert!(Requant::from_f64(v as f64).is_none(), "{v}");
        assert!(!is_rotation(&glam::Mat3::from_diagonal(Vec3::new(1.0, v, 1.0))));
        let (o, d) = (Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.1, 0.0, -1.0));
        for args in [(v, 10.0, 5.0, o, d), (10.0, 10.0, v, o, d), (10.0, 10.0, 5.0, Vec3::splat(v), d)] {
            assert!(ndc_ray(args.0, args.1, args.2, 1.0, args.3, args.4).is_none(), "{args:?}");
        }
    }
    assert_eq!(to_fixed(f32::INFINITY, 16), i32::MAX);
    assert_eq!(to_fixed(f32::NEG_INFINITY, 16), i32::MIN);
    // the network fed non-finite positions: finite colour; the density is
    // NaN, which every compositor reads as empty space
    let m = Model::from_bytes(F32).unwrap();
    let mut b = Box::<BlockF32<2>>::default();
    b.prepare_ray::<F32Path>(&m, &m.coarse, [f32::NAN, 0.0, 1.0]);
    b.eval_density::<F32Path>(&m, &m.coarse, &[[f32::NAN, 0.0, 0.0], [f32::INFINITY, 1.0, -1.0]], false);
    b.eval_colour::<F32Path>(&m, &m.coarse, &[0, 1]);
    assert!(b.rgb.iter().flatten().all(|c| (0.0..=1.0).contains(c)), "{:?}", b.rgb);
    assert!(b.sigma.iter().all(|&s| alpha_f32(s, 1.0) >= 0.0 && alpha_f32(s, 1.0) <= 1.0), "{:?}", b.sigma);
}

#[test]
fn wrong_path_and_bad_options_are_typed_errors() {
    let (mf, mq) = (Model::from_bytes(F32).unwrap(), Model::from_bytes(I16).unwrap());
    let e = RendererFixed::new(&mf, RenderOptions::from_model(&mf)).unwrap_err();
    assert_eq!(e, Error::WrongNumericPath(Scheme::F32));
    // the error names the renderer the model needs
    assert!(format!("{e}").contains("needs RendererF32"), "{e}");
    let e = RendererF32::new(&mq, RenderOptions::from_model(&mq)).unwrap_err();
    assert_eq!(e, Error::WrongNumericPath(Scheme::I16));
    assert!(format!("{e}").contains("needs RendererFixed"), "{e}");
    // and AnyRenderer takes both
    assert!(AnyRenderer::new(&mf, RenderOptions::from_model(&mf)).is_ok());
    assert!(AnyRenderer::new(&mq, RenderOptions::from_model(&mq)).is_ok());
    let mut o = RenderOptions::from_model(&mf);
    o.coarse = 1;
    assert_eq!(RendererF32::new(&mf, o).unwrap_err(), Error::InvalidSamples);
    o.coarse = 16;
    o.early_stop = f32::NAN;
    assert_eq!(RendererF32::new(&mf, o).unwrap_err(), Error::InvalidSamples);
}
