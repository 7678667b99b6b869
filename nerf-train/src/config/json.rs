//! The configuration as JSON: a `--config` file's fields over a preset's,
//! written nested (by section) or flat (each field by its flat name:
//! [`flat_names`]), or both.

use super::TrainConfig;
use crate::error::ConfigError;
use serde_json::{Map, Value};

/// The sections of [`TrainConfig`], as a `--config` file names them.
pub const SECTIONS: [&str; 7] = ["model", "features", "sampling", "grid", "optimiser", "loss", "per_photo"];

/// The prefix of a section's flat names (`feature_levels`, `grid_res`);
/// the other sections' fields go by their own names.
const FLAT_PREFIXES: [(&str, &str); 2] = [("features", "feature_"), ("grid", "grid_")];

/// Fields of a prefixed section whose flat name is their own: their names
/// already say which part they set.
const UNPREFIXED: [&str; 2] = ["footprint", "footprint_from"];

/// Fields that have moved to another section, as `(from, to)` paths
/// (`section.field`). A `--config` file that names one nested at its
/// former place is refused, naming the new one (its flat name is
/// unchanged); a checkpoint's configuration is read with each moved
/// ([`moved_fields_placed`]).
pub const MOVED: [(&str, &str); 3] = [
    ("loss.appearance", "per_photo.appearance"),
    ("loss.pose_refine", "per_photo.pose_refine"),
    ("optimiser.pose_lr", "per_photo.pose_lr"),
];

pub use crate::error::FlatName;

/// Every field's [`FlatName`], section by section, derived from the
/// sections' fields: the field's name, with its section's prefix in
/// `features` and `grid` (but `footprint` and `footprint_from`).
pub fn flat_names() -> &'static [FlatName] {
    static NAMES: std::sync::OnceLock<Vec<FlatName>> = std::sync::OnceLock::new();
    NAMES.get_or_init(|| {
        let value = serde_json::to_value(TrainConfig::default()).unwrap_or_default();
        let mut names = Vec::new();
        for section in SECTIONS {
            let prefix = FLAT_PREFIXES.iter().find(|(s, _)| *s == section).map_or("", |p| p.1);
            for field in value.get(section).and_then(Value::as_object).into_iter().flat_map(|s| s.keys()) {
                let flat = match UNPREFIXED.contains(&field.as_str()) {
                    true => field.clone(),
                    false => format!("{prefix}{field}"),
                };
                names.push(FlatName { flat, section, field: field.clone() });
            }
        }
        names
    })
}

/// `cfg`, a whole configuration as JSON that an earlier build may have
/// written (a checkpoint's), with each field of [`MOVED`] found at its
/// former place put in its new one (a value already there is kept).
pub fn moved_fields_placed(cfg: &mut Value) {
    for (from, to) in MOVED {
        let (Some((fs, ff)), Some((ts, tf))) = (from.split_once('.'), to.split_once('.')) else { continue };
        let Some(v) = cfg.get_mut(fs).and_then(Value::as_object_mut).and_then(|s| s.remove(ff)) else { continue };
        if let Some(Value::Object(into)) =
            cfg.as_object_mut().map(|c| c.entry(ts).or_insert_with(|| Value::Object(Map::new())))
        {
            into.entry(tf).or_insert(v);
        }
    }
}

impl TrainConfig {
    /// This configuration changed by `edit`: `TrainConfig::fast().with(|c|
    /// c.sampling.n_fine = None)`.
    pub fn with(mut self, edit: impl FnOnce(&mut Self)) -> Self {
        edit(&mut self);
        self
    }

    /// This configuration with the fields of `over` (a JSON object, nested,
    /// flat or both; [`nested`]) in place of its own. Fails with
    /// [`ConfigError`] naming an unknown section or field, a field named
    /// twice, or a field's value of the wrong type (`section.field: why`);
    /// the result is not validated.
    pub fn overlay(&self, over: &Value) -> Result<TrainConfig, ConfigError> {
        let over = nested(over)?;
        let mut merged = serde_json::to_value(self).map_err(ConfigError::Json)?;
        for (section, fields) in over {
            let Value::Object(fields) = fields else {
                return Err(ConfigError::NotASection { section });
            };
            let Some(Value::Object(into)) = merged.get_mut(section.as_str()) else {
                return Err(ConfigError::UnknownSection { section });
            };
            // each field against this configuration's section, so that a refusal names it
            for (field, value) in fields {
                let path = format!("{section}.{field}");
                if let Some(&(_, to)) = MOVED.iter().find(|(from, _)| *from == path) {
                    let (ts, tf) = to.split_once('.').unwrap_or((to, ""));
                    let flat = flat_names().iter().find(|n| n.section == ts && n.field == tf);
                    let flat = flat.map_or(tf, |n| n.flat.as_str()).to_string();
                    return Err(ConfigError::Moved { from: path, to, flat });
                }
                let mut one = into.clone();
                one.insert(field.clone(), value);
                check_section(&section, Value::Object(one.clone()))
                    .map_err(|source| ConfigError::Value { field: path, source })?;
                *into = one;
            }
        }
        serde_json::from_value(merged).map_err(ConfigError::Json)
    }

    /// The fields, as `section.field`, whose values differ between this
    /// configuration and `other`.
    pub fn differing_fields(&self, other: &TrainConfig) -> Vec<String> {
        let (a, b) = (serde_json::to_value(self).unwrap_or_default(), serde_json::to_value(other).unwrap_or_default());
        let mut differ = Vec::new();
        for section in SECTIONS {
            for (field, v) in a.get(section).and_then(Value::as_object).into_iter().flatten() {
                if b.get(section).and_then(|s| s.get(field)) != Some(v) {
                    differ.push(format!("{section}.{field}"));
                }
            }
        }
        differ
    }
}

/// Reads `value` as the section `section` of [`TrainConfig`].
/// Parses a configuration's JSON text, refusing a key that appears twice
/// in one object (JSON parsers keep the last and drop the first in silence:
/// a section written twice would lose the first one's fields).
pub fn parse(text: &str) -> Result<Value, serde_json::Error> {
    use serde::de::{DeserializeSeed, Deserializer, Error as _, MapAccess, SeqAccess, Visitor};
    /// A JSON value whose objects hold each key once.
    struct Unique;
    impl<'de> DeserializeSeed<'de> for Unique {
        type Value = Value;
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Value, D::Error> {
            d.deserialize_any(self)
        }
    }
    impl<'de> Visitor<'de> for Unique {
        type Value = Value;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a JSON value")
        }
        fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
            Ok(v.into())
        }
        fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
            Ok(v.into())
        }
        fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
            Ok(v.into())
        }
        fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
            Ok(v.into())
        }
        fn visit_str<E>(self, v: &str) -> Result<Value, E> {
            Ok(v.into())
        }
        fn visit_unit<E>(self) -> Result<Value, E> {
            Ok(Value::Null)
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
            let mut v = Vec::new();
            while let Some(x) = seq.next_element_seed(Unique)? {
                v.push(x);
            }
            Ok(Value::Array(v))
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
            let mut m = Map::new();
            while let Some(k) = map.next_key::<String>()? {
                if m.contains_key(&k) {
                    return Err(A::Error::custom(format!("the key `{k}` appears twice in one object")));
                }
                let v = map.next_value_seed(Unique)?;
                m.insert(k, v);
            }
            Ok(Value::Object(m))
        }
    }
    let mut de = serde_json::Deserializer::from_str(text);
    let v = Unique.deserialize(&mut de)?;
    de.end()?;
    Ok(v)
}

fn check_section(section: &str, value: Value) -> Result<(), serde_json::Error> {
    use super::sections::*;
    use serde::de::Error as _;
    match section {
        "model" => serde_json::from_value::<ModelConfig>(value).map(drop),
        "features" => serde_json::from_value::<FeatureConfig>(value).map(drop),
        "sampling" => serde_json::from_value::<SamplingConfig>(value).map(drop),
        "grid" => serde_json::from_value::<GridConfig>(value).map(drop),
        "optimiser" => serde_json::from_value::<OptimiserConfig>(value).map(drop),
        "loss" => serde_json::from_value::<LossConfig>(value).map(drop),
        "per_photo" => serde_json::from_value::<PerPhotoConfig>(value).map(drop),
        other => Err(serde_json::Error::custom(format!("unknown section `{other}`"))),
    }
}

/// Whether a `--config` object names `section.field`, nested or flat.
pub fn names(over: &Value, section: &str, field: &str) -> bool {
    nested(over).is_ok_and(|m| m.get(section).and_then(|s| s.get(field)).is_some())
}

/// A `--config` object with its flat names ([`flat_names`]) moved into
/// their sections. Fails with [`ConfigError`] on a value that is not an
/// object, a name that is neither a section nor a flat name, or a field
/// given both ways.
pub fn nested(over: &Value) -> Result<Map<String, Value>, ConfigError> {
    let Value::Object(over) = over else {
        return Err(ConfigError::NotAnObject);
    };
    let mut out = Map::new();
    let mut flat = Vec::new();
    for (key, value) in over {
        if SECTIONS.contains(&key.as_str()) {
            out.insert(key.clone(), value.clone());
        } else if let Some(n) = flat_names().iter().find(|n| n.flat == *key) {
            flat.push((n.section, n.field.as_str(), value));
        } else {
            let within = flat_names().iter().find(|n| n.field == *key).cloned();
            return Err(ConfigError::UnknownName { name: key.clone(), sections: &SECTIONS, within });
        }
    }
    for (section, field, value) in flat {
        let into = out.entry(section).or_insert_with(|| Value::Object(Map::new()));
        let Value::Object(into) = into else {
            return Err(ConfigError::NotASection { section: section.to_string() });
        };
        if into.insert(field.to_string(), value.clone()).is_some() {
            return Err(ConfigError::Twice { section, field: field.to_string() });
        }
    }
    Ok(out)
}
