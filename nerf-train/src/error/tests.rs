//! The errors' messages word for word, and the causes they keep.

use super::*;

#[test]
fn an_io_error_names_its_file_and_keeps_the_systems_reason() {
    let e = Error::io(Path::new("out/plot.png"))(std::io::Error::from(std::io::ErrorKind::PermissionDenied));
    let message = e.to_string();
    assert!(message.starts_with("out/plot.png: ") && message.to_lowercase().contains("permission denied"), "{message}");
    let source = std::error::Error::source(&e).and_then(|s| s.downcast_ref::<std::io::Error>());
    assert_eq!(source.map(|s| s.kind()), Some(std::io::ErrorKind::PermissionDenied));
}

#[test]
fn typed_causes_read_as_one_line_naming_the_field_or_file() {
    let cases: [(Error, &str); 8] = [
        (
            ConfigError::invalid("optimiser.lr", format!("{} must be a step size in (0, 1]", number(2.0f32))).into(),
            "optimiser.lr 2 must be a step size in (0, 1]",
        ),
        (
            ConfigError::Moved { from: "loss.appearance".into(), to: "per_photo.appearance", flat: "appearance".into() }
                .into(),
            "`loss.appearance` is `per_photo.appearance` (`{\"per_photo\": {\"appearance\": …}}`, or by its flat \
             name `appearance`)",
        ),
        (
            ConfigError::UnknownName {
                name: "res".into(),
                sections: &crate::config::json::SECTIONS,
                within: Some(crate::config::json::FlatName { flat: "grid_res".into(), section: "grid", field: "res".into() }),
            }
            .into(),
            "unknown field `res`: expected a section (model, features, sampling, grid, optimiser, loss, per_photo) or \
             a field's flat name (the field `res` of `grid` is `{\"grid\": {\"res\": …}}` or `grid_res`)",
        ),
        (
            CheckpointError::Version { found: 7, min: 18, max: 19 }.into(),
            "not a valid checkpoint: checkpoint version 7, this build reads versions 18 to 19 (written by another build)",
        ),
        (
            CameraError::RaysMiss { share: 0.001234, bounds_min: [-1.0; 3], bounds_max: [1.0; 3], near: 0.5, far: 4.0 }
                .into(),
            "only 0.12 % of the training rays meet the scene box [-1.0, -1.0, -1.0]..[1.0, 1.0, 1.0] within near 0.5 \
             .. far 4: the cameras look away from it or the bounds are wrong; check the poses, the aabb/near/far of \
             the transforms file, or try --scene unbounded",
        ),
        (
            FileError::CameraPath {
                path: "p.json".into(),
                reason: CameraPathError::Entry {
                    kind: "keyframe",
                    index: 0,
                    reason: PathEntryError::BottomRow { row: [1.0, 1.0, 1.0, 5.0] },
                },
            }
            .into(),
            "p.json: keyframe 0: its matrix's bottom row is 1 1 1 5, not 0 0 0 1 (not a rigid transform)",
        ),
        (
            FileError::CameraPath {
                path: "p.json".into(),
                reason: CameraPathError::Frames { fps: 5.0, seconds: 1e308, frames: f64::INFINITY },
            }
            .into(),
            "p.json: fps 5 × seconds 1e308 gives inf frames (1 to 100000 are rendered)",
        ),
        (
            FileError::Unreadable {
                path: "a.json".into(),
                what: "camera path".into(),
                reason: ReadError::TooLarge { size: 10, max: 2 },
            }
            .into(),
            "a.json: camera path: 10 bytes, more than the 2 accepted",
        ),
    ];
    for (e, message) in cases {
        assert_eq!(e.to_string(), message);
    }
}

#[test]
fn a_typed_cause_keeps_the_other_crates_error_as_its_source() {
    let io = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
    let reason = ReadError::Io { action: "cannot read", source: io };
    let e = Error::from(FileError::Unreadable { path: "m.nerf".into(), what: "model file".into(), reason });
    let read = std::error::Error::source(&e).and_then(|s| s.downcast_ref::<ReadError>());
    assert!(matches!(read, Some(ReadError::Io { action: "cannot read", .. })), "{read:?}");
    let io = read.and_then(std::error::Error::source).and_then(|s| s.downcast_ref::<std::io::Error>());
    assert_eq!(io.map(|s| s.kind()), Some(std::io::ErrorKind::PermissionDenied));
    let e = Error::from(CheckpointError::Decode(postcard::Error::DeserializeUnexpectedEnd));
    let cause = std::error::Error::source(&e).and_then(|s| s.downcast_ref::<CheckpointError>());
    let postcard = cause.and_then(std::error::Error::source).and_then(|s| s.downcast_ref::<postcard::Error>());
    assert_eq!(postcard, Some(&postcard::Error::DeserializeUnexpectedEnd));
    assert!(e.to_string().starts_with("not a valid checkpoint: cannot decode: "), "{e}");
}
