//! Presets refined to the photos, and configurations refused by field.

use super::*;
use std::num::NonZeroU8;

#[test]
fn fitted_samples_only_ever_grow_and_only_in_one_pass_marches_over_a_grid() {
    let mut c = TrainConfig::features();
    // lego at 100×100 resolves 256 cells: the preset's 192 samples stay
    assert!(!c.fit_samples_to(256));
    assert_eq!(c.sampling.n_coarse, 192);
    // at 800×800, 2048 cells: one sample per four cells
    assert!(c.fit_samples_to(2048));
    assert_eq!(c.sampling.n_coarse, 512);
    assert!(c.validate().is_ok());
    assert!(!c.fit_samples_to(1024));
    assert_eq!(c.sampling.n_coarse, 512);
    // at most the march's capacity
    assert!(c.fit_samples_to(1 << 20));
    assert_eq!(c.sampling.n_coarse as usize, nerf_infer::format::MAX_MARCH);
    assert!(c.validate().is_ok());
    // no occupancy grid, or a fine pass: left alone
    for c in [TrainConfig::fast(), TrainConfig::features().with(|c| c.grid.res = None)] {
        let mut fitted = c.clone();
        assert!(!fitted.fit_samples_to(4096));
        assert_eq!(fitted, c);
    }
}

#[test]
fn the_regularisers_weights_must_be_finite_and_not_negative() {
    let c = TrainConfig::features();
    let with = |feature_decay: f32, density_l1: f32| {
        c.clone().with(|c| {
            c.optimiser.feature_decay = feature_decay;
            c.loss.density_l1 = density_l1;
        })
    };
    assert!(with(0.0, 0.0).validate().is_ok());
    assert!(with(0.1, 1e-5).validate().is_ok());
    // lr 1e-2: a decay of 100 scales the table by 0 each step, above it by less than 0
    assert!(with(100.0, 0.0).validate().is_ok());
    for (d, l1) in [(-0.1, 0.0), (f32::NAN, 0.0), (f32::INFINITY, 0.0), (101.0, 0.0), (0.0, -1e-5), (0.0, f32::NAN)] {
        let e = with(d, l1).validate().unwrap_err().to_string();
        assert!(e.contains(if l1 != 0.0 { "density_l1" } else { "feature_decay" }), "{e}");
    }
}

#[test]
fn the_near_gradient_distance_is_finite_not_negative_and_needs_one_network() {
    let with = |d0: f32| TrainConfig::features().with(|c| c.loss.near_gradient = d0);
    assert!(with(0.0).validate().is_ok());
    assert!(with(0.5).validate().is_ok());
    for d0 in [-0.1, f32::NAN, f32::INFINITY] {
        let e = with(d0).validate().unwrap_err().to_string();
        assert!(e.contains("near_gradient"), "{e}");
    }
    // the fine pass is not scaled: a two-network run is refused
    let two = TrainConfig::fast().with(|c| c.loss.near_gradient = 0.5);
    assert!(TrainConfig::fast().validate().is_ok());
    let e = two.validate().unwrap_err().to_string();
    assert!(e.contains("near_gradient") && e.contains("n_fine"), "{e}");
}

#[test]
fn the_backward_transmittance_is_a_share_of_light_below_1() {
    let with = |t: f32| TrainConfig::features().with(|c| c.loss.backward_transmittance = t);
    assert!(with(0.0).validate().is_ok() && with(1e-4).validate().is_ok());
    for t in [-1e-4, 1.0, f32::NAN, f32::INFINITY] {
        assert!(with(t).validate().unwrap_err().to_string().contains("backward_transmittance"), "{t}");
    }
}

#[test]
fn the_footprint_starts_at_a_share_of_the_run_in_0_to_1() {
    let with = |footprint_from: f32| TrainConfig::features().with(|c| c.features.footprint_from = footprint_from);
    assert!(with(0.0).validate().is_ok() && with(0.5).validate().is_ok());
    for v in [-0.1, 1.0, f32::NAN] {
        assert!(with(v).validate().unwrap_err().to_string().contains("footprint_from"), "{v}");
    }
    // a jittered ray across its pixel, read again across its footprint
    let jittered = TrainConfig::features().with(|c| c.sampling.pixel_jitter = true);
    assert!(jittered.validate().unwrap_err().to_string().contains("pixel_jitter"));
    assert!(jittered.with(|c| c.features.footprint = false).validate().is_ok());
}

#[test]
fn the_parameters_average_decays_in_0_to_1() {
    let with = |ema_decay: f32| TrainConfig::features().with(|c| c.optimiser.ema_decay = ema_decay);
    assert!(with(0.0).validate().is_ok() && with(0.999).validate().is_ok());
    for v in [-0.1, 1.0, 2.0, f32::NAN] {
        assert!(with(v).validate().unwrap_err().to_string().contains("ema_decay"), "{v}");
    }
}

#[test]
fn fitting_the_feature_grid_only_ever_refines_it() {
    // 256 cells in 2^15 entries: 2048 cells are three doublings, three more powers of two of entries
    let mut c = TrainConfig::features();
    assert!(c.fit_features_to(2048));
    assert_eq!((c.features.max_res, c.features.log2_table), (2048, 18));
    assert!(c.validate().is_ok());
    // a grid as fine as the photos, or finer, is left alone
    for cells in [2048, 1024, 1] {
        assert!(!c.fit_features_to(cells));
        assert_eq!((c.features.max_res, c.features.log2_table), (2048, 18));
    }
    // at most MAX_RES cells and 2^19 entries; a table already larger keeps its size
    let mut c = TrainConfig::features();
    assert!(c.fit_features_to(1 << 20));
    assert_eq!((c.features.max_res, c.features.log2_table), (MAX_RES, TrainConfig::FITTED_LOG2_TABLE));
    let mut c = TrainConfig::features().with(|c| c.features.log2_table = 21);
    assert!(c.fit_features_to(512));
    assert_eq!((c.features.max_res, c.features.log2_table), (512, 21));
    // a configuration without a feature grid, or with one level (at features.min_res), has nothing to fit
    for c in [TrainConfig::grid(), TrainConfig::features().with(|c| c.features.levels = NonZeroU8::new(1))] {
        let mut fitted = c.clone();
        assert!(!fitted.fit_features_to(4096));
        assert_eq!(fitted, c);
    }
}

#[test]
fn a_one_pass_march_takes_up_to_1024_samples_and_a_two_pass_one_256() {
    use nerf_infer::format::{MAX_COARSE, MAX_MARCH};
    let one = TrainConfig::fast().with(|c| {
        c.sampling.n_coarse = MAX_MARCH as u16;
        c.sampling.n_fine = None;
    });
    assert!(one.validate().is_ok());
    assert!(one.with(|c| c.sampling.n_coarse = MAX_MARCH as u16 + 1).validate().is_err());
    let two = TrainConfig::fast().with(|c| {
        c.sampling.n_coarse = MAX_COARSE as u16;
        c.sampling.n_fine = NonZeroU16::new(24);
    });
    assert!(two.validate().is_ok());
    assert!(two.with(|c| c.sampling.n_coarse = MAX_COARSE as u16 + 1).validate().is_err());
}

#[test]
fn a_two_pass_march_takes_at_least_the_3_coarse_samples_a_model_holds() {
    let two = |n| TrainConfig::fast().with(|c| c.sampling.n_coarse = n);
    assert!(two(3).validate().is_ok());
    let e = two(2).validate().unwrap_err().to_string();
    assert!(e.contains("sampling.n_coarse must be 2..=1024 (3..=256 with sampling.n_fine)"), "{e}");
    assert!(two(2).with(|c| c.sampling.n_fine = None).validate().is_ok());
}

#[test]
fn a_config_file_may_name_fields_nested_or_by_their_flat_names() {
    use serde_json::json;
    let base = TrainConfig::features();
    let nested = base.overlay(&json!({"sampling": {"n_coarse": 64}, "grid": {"res": 32}})).unwrap();
    let flat = base.overlay(&json!({"n_coarse": 64, "grid_res": 32})).unwrap();
    let mixed = base.overlay(&json!({"sampling": {"n_coarse": 64}, "grid_res": 32})).unwrap();
    assert_eq!(
        nested,
        base.clone().with(|c| {
            c.sampling.n_coarse = 64;
            c.grid.res = NonZeroU16::new(32);
        })
    );
    assert_eq!(flat, nested);
    assert_eq!(mixed, nested);
    assert_eq!(nested.differing_fields(&base), ["sampling.n_coarse", "grid.res"]);
    assert!(json::names(&json!({"feature_max_res": 512}), "features", "max_res"));
    assert!(!json::names(&json!({"features": {"levels": 4}}), "features", "max_res"));
    // refused, naming what is wrong
    for (over, says) in [
        (json!({"n_coarse": 64, "sampling": {"n_coarse": 48}}), "sampling.n_coarse` is given twice"),
        (json!({"n_coarses": 64}), "unknown field `n_coarses`"),
        (json!({"sampling": {"grid_res": 64}}), "`sampling.grid_res`: unknown field `grid_res`"),
        (json!({"sampling": 3}), "`sampling` must be an object"),
        (json!({"sampling": {"n_coarse": "many"}}), "`sampling.n_coarse`: invalid type"),
        (json!({"grid_alpha": "dense"}), "`grid.alpha`: invalid type"),
        (json!({"levels": 4}), "`{\"features\": {\"levels\": …}}` or `feature_levels`"),
        (json!([1, 2]), "expected a JSON object"),
    ] {
        let e = base.overlay(&over).unwrap_err().to_string();
        assert!(e.contains(says), "{over}: {e}");
    }
}

#[test]
fn every_field_has_one_flat_name_that_reads_back_to_it() {
    let base = TrainConfig::features();
    let value = serde_json::to_value(&base).unwrap();
    let fields: usize = json::SECTIONS.iter().map(|s| value[s].as_object().unwrap().len()).sum();
    assert_eq!(fields, json::flat_names().len());
    let mut seen = std::collections::HashSet::new();
    let mut flats = std::collections::HashSet::new();
    for json::FlatName { flat, section, field } in json::flat_names() {
        let (section, field) = (*section, field.as_str());
        assert!(flats.insert(flat), "{flat} names two fields");
        assert!(seen.insert((section, field)), "{flat}: {section}.{field} has two flat names");
        // a value other than the base's, of the field's type
        let other = match &value[section][field] {
            serde_json::Value::Bool(b) => serde_json::json!(!b),
            serde_json::Value::Array(_) => serde_json::json!([1]),
            serde_json::Value::Number(n) => match n.as_u64() {
                Some(n) => serde_json::json!(n + 1),
                None => serde_json::json!(n.as_f64().unwrap() + 0.5),
            },
            v => panic!("{flat}: no field {section}.{field} ({v})"),
        };
        let changed = base.overlay(&serde_json::json!({ flat: other })).unwrap();
        assert_eq!(changed.differing_fields(&base), [format!("{section}.{field}")], "{flat}");
    }
}

#[test]
fn a_key_written_twice_is_refused_by_name() {
    let e = super::json::parse(r#"{"sampling": {"n_coarse": 64}, "sampling": {"n_main": 8}}"#).unwrap_err();
    assert!(e.to_string().contains("the key `sampling` appears twice"), "{e}");
    let e = super::json::parse(r#"{"sampling": {"n_coarse": 64, "n_coarse": 8}}"#).unwrap_err();
    assert!(e.to_string().contains("the key `n_coarse` appears twice"), "{e}");
    let v = super::json::parse(r#"{"a": [1, -2, 0.5, "x", null, true, {"b": {}}]}"#).unwrap();
    assert_eq!(v, serde_json::json!({"a": [1, -2, 0.5, "x", null, true, {"b": {}}]}));
    assert!(super::json::parse(r#"{"a": 1} trailing"#).is_err());
}

#[test]
fn a_moved_field_is_refused_at_its_former_place_naming_the_new_one_and_read_there_from_a_checkpoint() {
    let base = TrainConfig::features();
    for (from, to) in json::MOVED {
        let (fs, ff) = from.split_once('.').unwrap();
        let e = base.overlay(&serde_json::json!({ fs: { ff: true } })).unwrap_err().to_string();
        assert!(e.contains(&format!("`{from}` is `{to}`")), "{e}");
    }
    // the flat names still set the moved fields
    let c = base.overlay(&serde_json::json!({"appearance": true, "pose_refine": true, "pose_lr": 6e-4})).unwrap();
    assert!(c.per_photo.appearance && c.per_photo.pose_refine && c.per_photo.pose_lr == 6e-4);
    // a configuration written with the fields at their former places reads with them moved
    let mut old = serde_json::to_value(&base).unwrap();
    let per_photo = old.as_object_mut().unwrap().remove("per_photo").unwrap();
    old["loss"]["appearance"] = serde_json::json!(true);
    old["loss"]["pose_refine"] = per_photo["pose_refine"].clone();
    old["optimiser"]["pose_lr"] = serde_json::json!(6e-4);
    json::moved_fields_placed(&mut old);
    let read: TrainConfig = serde_json::from_value(old).unwrap();
    assert_eq!(
        read,
        base.with(|c| {
            c.per_photo.appearance = true;
            c.per_photo.pose_lr = 6e-4;
        })
    );
}

#[test]
fn every_preset_validates_under_its_own_name_and_fit_tries_every_shape_once() {
    let mut names = std::collections::HashSet::new();
    for p in Preset::ALL {
        p.config().validate().unwrap_or_else(|e| panic!("{}: {e}", p.name()));
        assert!(names.insert(p.name()), "{} named twice", p.name());
    }
    let mut shapes = std::collections::HashSet::new();
    for p in Preset::FIT {
        let c = p.config();
        assert!(
            c.grid.res.is_some() && c.model.width % 32 == 0,
            "{}: no occupancy grid or a width off the tile",
            p.name()
        );
        assert!(shapes.insert(format!("{:?}{:?}", c.model, c.features)), "{} repeats a shape", p.name());
    }
}

/// The default configuration, then every preset's.
fn every_preset() -> Vec<TrainConfig> {
    std::iter::once(TrainConfig::default()).chain(Preset::ALL.map(Preset::config)).collect()
}

/// The five fields that turn a part off, as `section.field`.
const MODES: [&str; 5] =
    ["features.levels", "grid.res", "sampling.n_fine", "sampling.proposal_res", "sampling.n_main_render"];

/// [`MODES`]' values, as the integers JSON and postcard write them (0:
/// `None`).
fn modes(c: &TrainConfig) -> [u16; 5] {
    let int = |n: Option<NonZeroU16>| n.map_or(0, NonZeroU16::get);
    let s = &c.sampling;
    [
        c.features.levels.map_or(0, |n| n.get().into()),
        int(c.grid.res),
        int(s.n_fine),
        int(s.proposal_res),
        int(s.n_main_render),
    ]
}

#[test]
fn the_modes_are_written_to_json_as_integers_0_when_off_and_read_back() {
    let configs = every_preset();
    // the presets have each part both off and on: paper two networks and no grid, features the reverse
    assert_eq!(modes(&TrainConfig::paper()), [0, 0, 128, 0, 0]);
    assert_eq!(modes(&TrainConfig::features()), [8, 64, 0, 0, 0]);
    let on = TrainConfig::features().with(|c| {
        (c.sampling.proposal_res, c.sampling.n_main_render) = (NonZeroU16::new(128), NonZeroU16::new(255));
        c.grid.res = NonZeroU16::new(256);
    });
    for c in configs.iter().chain([&on]) {
        let v = serde_json::to_value(c).unwrap();
        let written = MODES.map(|path| {
            let (section, field) = path.split_once('.').unwrap();
            v[section][field].as_u64().unwrap_or_else(|| panic!("{path}: {}", v[section][field])) as u16
        });
        assert_eq!(written, modes(c));
        assert_eq!(&serde_json::from_value::<TrainConfig>(v).unwrap(), c);
        assert_eq!(&serde_json::from_str::<TrainConfig>(&serde_json::to_string(c).unwrap()).unwrap(), c);
    }
}

#[test]
fn the_modes_postcard_bytes_are_those_of_plain_integers() {
    fn bytes(v: &impl serde::Serialize) -> Vec<u8> {
        postcard::to_stdvec(v).unwrap()
    }
    let edges = TrainConfig::fast().with(|c| {
        // multi-byte varints (above 127), the largest values in range
        (c.sampling.n_fine, c.sampling.proposal_res, c.sampling.n_main_render) =
            (NonZeroU16::new(256), NonZeroU16::new(128), NonZeroU16::new(255));
        (c.grid.res, c.features.levels) = (NonZeroU16::new(256), NonZeroU8::new(16));
    });
    for c in every_preset().iter().chain([&edges]) {
        let [levels, res, n_fine, proposal_res, n_main_render] = modes(c);
        let (f, s, g) = (&c.features, &c.sampling, &c.grid);
        let plain_features = (levels as u8, f.width, f.log2_table, f.min_res, f.max_res, f.footprint, f.footprint_from);
        let plain_sampling = (
            s.n_coarse,
            n_fine,
            s.batch_rays,
            s.chunk_rays,
            s.random_background,
            s.pixel_jitter,
            proposal_res,
            s.n_main,
            n_main_render,
        );
        let plain_grid = (res, g.warmup, g.every, g.alpha);
        assert_eq!(bytes(f), bytes(&plain_features), "{f:?}");
        assert_eq!(bytes(s), bytes(&plain_sampling), "{s:?}");
        assert_eq!(bytes(g), bytes(&plain_grid), "{g:?}");
        assert_eq!(&postcard::from_bytes::<FeatureConfig>(&bytes(&plain_features)).unwrap(), f);
        assert_eq!(&postcard::from_bytes::<SamplingConfig>(&bytes(&plain_sampling)).unwrap(), s);
        assert_eq!(&postcard::from_bytes::<GridConfig>(&bytes(&plain_grid)).unwrap(), g);
    }
}

#[test]
fn a_config_file_turns_a_part_off_with_0_or_null_and_on_with_a_count() {
    use serde_json::json;
    let features = TrainConfig::features();
    for over in [json!({"grid_res": 0}), json!({"grid": {"res": 0}}), json!({"grid": {"res": null}})] {
        assert_eq!(features.overlay(&over).unwrap(), features.clone().with(|c| c.grid.res = None), "{over}");
    }
    let two = features.overlay(&json!({"n_fine": 64})).unwrap();
    assert_eq!(two, features.clone().with(|c| c.sampling.n_fine = NonZeroU16::new(64)));
    assert_eq!(two.differing_fields(&features), ["sampling.n_fine"]);
    let one = TrainConfig::fast().overlay(&json!({"sampling": {"n_fine": 0}, "feature_levels": 4})).unwrap();
    assert_eq!((one.sampling.n_fine, one.features.levels), (None, NonZeroU8::new(4)));
    assert!(one.validate().is_ok());
    // out of the integer's range, or not an integer: refused by name
    for (over, says) in [
        (json!({"grid_res": 65536}), "`grid.res`: invalid value"),
        (json!({"feature_levels": 256}), "`features.levels`: invalid value"),
        (json!({"n_main_render": -1}), "`sampling.n_main_render`: invalid value"),
        (json!({"proposal_res": "64"}), "`sampling.proposal_res`: invalid type"),
        (json!({"n_fine": 1.5}), "`sampling.n_fine`: invalid type"),
    ] {
        let e = features.overlay(&over).unwrap_err().to_string();
        assert!(e.contains(says), "{over}: {e}");
    }
    // above the range validate allows: read, then refused
    let e = features.overlay(&json!({"n_main_render": 256})).unwrap().validate().unwrap_err().to_string();
    assert!(e.contains("sampling.n_main_render must be 0..=255"), "{e}");
}

#[test]
fn configurations_no_network_or_grid_can_be_built_from_are_refused_naming_the_field() {
    let (features, two) = (TrainConfig::features(), TrainConfig::fast());
    let with = |c: &TrainConfig, edit: fn(&mut TrainConfig)| c.clone().with(edit);
    for (c, says) in [
        (with(&features, |c| c.features.levels = NonZeroU8::new(17)), "features.levels must be 1..=16"),
        (with(&features, |c| (c.features.levels, c.features.width) = (NonZeroU8::new(16), 16)), "features.levels"),
        (with(&features, |c| c.features.log2_table = 64), "features.log2_table must be 1..=22"),
        (with(&features, |c| c.model.depth = 0), "model.depth must be 1..=20"),
        (with(&features, |c| c.model.width = 0), "model.width 1..=256"),
        (with(&features, |c| (c.model.view_dependent, c.model.view_width) = (true, 0)), "model.view_width"),
        (with(&features, |c| c.sampling.chunk_rays = 0), "sampling.chunk_rays must be positive"),
        (with(&two, |c| c.grid.res = NonZeroU16::new(64)), "an occupancy grid needs sampling.n_fine = 0"),
        (with(&features, |c| c.grid.res = NonZeroU16::new(u16::MAX)), "grid.res must be at most 256"),
        (with(&features, |c| c.sampling.proposal_res = NonZeroU16::new(u16::MAX)), "sampling.proposal_res"),
        (
            with(&features, |c| (c.sampling.proposal_res, c.sampling.n_coarse) = (NonZeroU16::new(64), 0)),
            "sampling.n_coarse must be 2..=1024",
        ),
    ] {
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains(says), "{says}: {e}");
    }
}
