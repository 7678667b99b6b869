//! Checkpoints across builds: version 19's named sections read back whole,
//! version 18 still reads, and a field missing or unknown is named.

use super::checkpoint::{CHECKPOINT_VERSION, CHECKPOINT_VERSION_MIN};
use super::checkpoint_v18::V18;
use super::*;
use crate::error::{CheckpointError, Error};
use nerf_infer::format::{frame, unframe, CHECKPOINT_MAGIC};

/// A run of the fast preset with some state to keep: steps, time, a seed, data.
fn trainer() -> Trainer {
    let mut t = Trainer::new(TrainConfig::fast(), Scene::blender(1.5, 2.0, 6.0), 2, 11).unwrap();
    (t.step, t.elapsed, t.skipped, t.data, t.pixel) = (7, 1.25, 1, "/data/scene format: auto".into(), 0.003);
    t.field.adam.m.iter_mut().enumerate().for_each(|(i, m)| *m = i as f32 * 1e-3);
    t
}

/// `t`'s version 19 sections, for a test to change.
fn sections(t: &Trainer) -> Vec<(String, Vec<u8>)> {
    let bytes = t.to_bytes().unwrap();
    let (version, payload) = unframe(&bytes, &CHECKPOINT_MAGIC, CHECKPOINT_VERSION, CHECKPOINT_VERSION).unwrap();
    assert_eq!(version, 19);
    postcard::from_bytes(payload).unwrap()
}

/// A version 19 checkpoint of `sections`.
fn checkpoint(sections: &[(String, Vec<u8>)]) -> Vec<u8> {
    frame(&CHECKPOINT_MAGIC, CHECKPOINT_VERSION, &postcard::to_stdvec(sections).unwrap()).unwrap()
}

/// `sections` with the configuration's JSON changed by `f`.
fn with_cfg(sections: &[(String, Vec<u8>)], f: impl Fn(&mut serde_json::Value)) -> Vec<(String, Vec<u8>)> {
    sections
        .iter()
        .map(|(n, b)| {
            if n != "cfg" {
                return (n.clone(), b.clone());
            }
            let mut v: serde_json::Value = serde_json::from_str(&postcard::from_bytes::<String>(b).unwrap()).unwrap();
            f(&mut v);
            (n.clone(), postcard::to_stdvec(&v.to_string()).unwrap())
        })
        .collect()
}

#[test]
fn a_checkpoint_reads_back_as_the_state_it_was_written_from() {
    let t = trainer();
    let back = Trainer::from_bytes(&t.to_bytes().unwrap()).unwrap();
    assert_eq!(back.to_bytes().unwrap(), t.to_bytes().unwrap());
    assert_eq!((back.cfg, back.scene, back.step, back.data), (t.cfg.clone(), t.scene, 7, t.data.clone()));
    assert_eq!((back.field.params, back.field.adam.m), (t.field.params.clone(), t.field.adam.m.clone()));
}

#[test]
fn a_version_18_checkpoint_the_whole_state_in_postcard_still_reads() {
    let mut t = trainer();
    // a per-photo setting, which version 18 laid out in `optimiser`
    t.cfg.per_photo.pose_lr = 3e-4;
    let v18 = frame(&CHECKPOINT_MAGIC, CHECKPOINT_VERSION_MIN, &postcard::to_stdvec(&V18::from(&t)).unwrap()).unwrap();
    assert_eq!(Trainer::from_bytes(&v18).unwrap().to_bytes().unwrap(), t.to_bytes().unwrap());
    let v17 = frame(&CHECKPOINT_MAGIC, 17, &postcard::to_stdvec(&V18::from(&t)).unwrap()).unwrap();
    let e = Trainer::from_bytes(&v17).unwrap_err().to_string();
    assert!(e.contains("checkpoint version 17, this build reads versions 18 to 19"), "{e}");
}

#[test]
fn a_checkpoint_without_a_field_is_refused_naming_it() {
    let all = sections(&trainer());
    let without = |name: &str| -> Vec<_> { all.iter().filter(|(n, _)| n != name).cloned().collect() };
    for name in ["ema", "poses", "scene", "cfg"] {
        let e = Trainer::from_bytes(&checkpoint(&without(name))).unwrap_err().to_string();
        assert!(e.contains(&format!("it has no {name} (written by an earlier build")), "{name}: {e}");
    }
    let no_field = with_cfg(&all, |v| drop(v["loss"].as_object_mut().unwrap().remove("distortion")));
    let e = Trainer::from_bytes(&checkpoint(&no_field)).unwrap_err().to_string();
    assert!(e.contains("it has no cfg.loss.distortion"), "{e}");
    let no_section = with_cfg(&all, |v| drop(v.as_object_mut().unwrap().remove("grid")));
    let e = Trainer::from_bytes(&checkpoint(&no_section)).unwrap_err().to_string();
    assert!(e.contains("it has no cfg.grid"), "{e}");
}

#[test]
fn a_field_an_earlier_build_lacks_takes_the_value_that_means_what_it_did() {
    let t = trainer();
    let all = sections(&t);
    let no_field = with_cfg(&all, |v| drop(v["loss"].as_object_mut().unwrap().remove("distortion")));
    let without: Vec<_> = no_field.iter().filter(|(n, _)| n != "skipped").cloned().collect();
    let payload = postcard::to_stdvec(&without).unwrap();
    let absent = [("cfg.loss.distortion", "0.25"), ("skipped", "0")];
    let back = Trainer::from_sections(&payload, &absent).unwrap();
    assert_eq!((back.cfg.loss.distortion, back.skipped), (0.25, 0));
    assert_eq!((back.field.params, back.step), (t.field.params, t.step));
}

#[test]
fn a_checkpoint_without_the_backward_transmittance_keeps_every_sample() {
    let t = trainer();
    let earlier =
        with_cfg(&sections(&t), |v| drop(v["loss"].as_object_mut().unwrap().remove("backward_transmittance")));
    let back = Trainer::from_bytes(&checkpoint(&earlier)).unwrap();
    assert_eq!(back.cfg.loss.backward_transmittance, 0.0);
    assert_eq!(back.to_bytes().unwrap(), t.to_bytes().unwrap());
}

#[test]
fn a_checkpoint_with_a_moved_field_at_its_former_place_reads_it_in_the_new_one() {
    let mut t = trainer();
    t.cfg.per_photo.pose_lr = 3e-4;
    let moved_back = with_cfg(&sections(&t), |v| {
        let per_photo = v.as_object_mut().unwrap().remove("per_photo").unwrap();
        v["loss"]["appearance"] = per_photo["appearance"].clone();
        v["loss"]["pose_refine"] = per_photo["pose_refine"].clone();
        v["optimiser"]["pose_lr"] = per_photo["pose_lr"].clone();
    });
    let back = Trainer::from_bytes(&checkpoint(&moved_back)).unwrap();
    assert_eq!(back.to_bytes().unwrap(), t.to_bytes().unwrap());
}

#[test]
fn a_checkpoint_with_a_field_this_build_does_not_know_is_refused_naming_it() {
    let mut all = sections(&trainer());
    let cfg = with_cfg(&all, |v| drop(v["sampling"].as_object_mut().unwrap().insert("n_third".into(), 3.into())));
    let e = Trainer::from_bytes(&checkpoint(&cfg)).unwrap_err().to_string();
    assert!(e.contains("it holds cfg.sampling.n_third, which this build does not know"), "{e}");
    all.push(("second_proposal".into(), vec![0]));
    let e = Trainer::from_bytes(&checkpoint(&all)).unwrap_err().to_string();
    assert!(e.contains("it holds second_proposal, which this build does not know (written by a newer build)"), "{e}");
}

#[test]
fn a_checkpoint_whose_configuration_fails_validation_is_refused_as_an_inconsistent_cfg() {
    let all = sections(&trainer());
    let invalid = with_cfg(&all, |v| v["sampling"]["n_coarse"] = 1.into());
    let mut t = trainer();
    t.cfg.sampling.n_coarse = 1;
    let v18 = frame(&CHECKPOINT_MAGIC, CHECKPOINT_VERSION_MIN, &postcard::to_stdvec(&V18::from(&t)).unwrap()).unwrap();
    for bytes in [checkpoint(&invalid), v18] {
        let e = Trainer::from_bytes(&bytes).unwrap_err();
        assert!(matches!(e, Error::Checkpoint(CheckpointError::Inconsistent { part: "cfg" })), "{e:?}");
    }
}
