//! The configuration as JSON: a `--config` file's fields over a preset's,
//! written nested (by section) or flat (each field by its flat name:
//! [`FLAT_NAMES`]), or both.

use super::TrainConfig;
use crate::error::Error;
use serde_json::{Map, Value};

/// The sections of [`TrainConfig`], as a `--config` file names them.
pub const SECTIONS: [&str; 6] = ["model", "features", "sampling", "grid", "optimiser", "loss"];

/// Each field's flat name (a `--config` file without sections), its
/// section and its name there.
pub const FLAT_NAMES: [(&str, &str, &str); 43] = [
    ("pos_freqs", "model", "pos_freqs"),
    ("dir_freqs", "model", "dir_freqs"),
    ("include_input", "model", "include_input"),
    ("depth", "model", "depth"),
    ("width", "model", "width"),
    ("skips", "model", "skips"),
    ("view_dependent", "model", "view_dependent"),
    ("view_width", "model", "view_width"),
    ("feature_levels", "features", "levels"),
    ("feature_width", "features", "width"),
    ("feature_log2_table", "features", "log2_table"),
    ("feature_min_res", "features", "min_res"),
    ("feature_max_res", "features", "max_res"),
    ("footprint", "features", "footprint"),
    ("footprint_from", "features", "footprint_from"),
    ("n_coarse", "sampling", "n_coarse"),
    ("n_fine", "sampling", "n_fine"),
    ("n_main", "sampling", "n_main"),
    ("n_main_render", "sampling", "n_main_render"),
    ("proposal_res", "sampling", "proposal_res"),
    ("batch_rays", "sampling", "batch_rays"),
    ("chunk_rays", "sampling", "chunk_rays"),
    ("random_background", "sampling", "random_background"),
    ("pixel_jitter", "sampling", "pixel_jitter"),
    ("grid_res", "grid", "res"),
    ("grid_warmup", "grid", "warmup"),
    ("grid_every", "grid", "every"),
    ("grid_alpha", "grid", "alpha"),
    ("lr", "optimiser", "lr"),
    ("lr_final_ratio", "optimiser", "lr_final_ratio"),
    ("lr_decay_steps", "optimiser", "lr_decay_steps"),
    ("beta1", "optimiser", "beta1"),
    ("beta2", "optimiser", "beta2"),
    ("eps", "optimiser", "eps"),
    ("proposal_lr", "optimiser", "proposal_lr"),
    ("pose_lr", "optimiser", "pose_lr"),
    ("feature_decay", "optimiser", "feature_decay"),
    ("ema_decay", "optimiser", "ema_decay"),
    ("distortion", "loss", "distortion"),
    ("density_l1", "loss", "density_l1"),
    ("near_gradient", "loss", "near_gradient"),
    ("appearance", "loss", "appearance"),
    ("pose_refine", "loss", "pose_refine"),
];

impl TrainConfig {
    /// This configuration changed by `edit`: `TrainConfig::fast().with(|c|
    /// c.sampling.n_fine = 0)`.
    pub fn with(mut self, edit: impl FnOnce(&mut Self)) -> Self {
        edit(&mut self);
        self
    }

    /// This configuration with the fields of `over` (a JSON object, nested,
    /// flat or both; [`nested`]) in place of its own. Fails with
    /// [`Error::Config`] naming an unknown section or field, a field named
    /// twice, or a field's value of the wrong type (`section.field: why`);
    /// the result is not validated.
    pub fn overlay(&self, over: &Value) -> Result<TrainConfig, Error> {
        let over = nested(over)?;
        let mut merged = serde_json::to_value(self).map_err(|e| Error::Config(e.to_string()))?;
        for (section, fields) in over {
            let Value::Object(fields) = fields else {
                return Err(Error::Config(format!("`{section}` must be an object of fields")));
            };
            let Some(Value::Object(into)) = merged.get_mut(section.as_str()) else {
                return Err(Error::Config(format!("unknown section `{section}`")));
            };
            // each field against this configuration's section, so that a refusal names it
            for (field, value) in fields {
                let mut one = into.clone();
                one.insert(field.clone(), value);
                check_section(&section, Value::Object(one.clone()))
                    .map_err(|e| Error::Config(format!("`{section}.{field}`: {e}")))?;
                *into = one;
            }
        }
        serde_json::from_value(merged).map_err(|e| Error::Config(e.to_string()))
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
        other => Err(serde_json::Error::custom(format!("unknown section `{other}`"))),
    }
}

/// Whether a `--config` object names `section.field`, nested or flat.
pub fn names(over: &Value, section: &str, field: &str) -> bool {
    nested(over).is_ok_and(|m| m.get(section).and_then(|s| s.get(field)).is_some())
}

/// A `--config` object with its flat names ([`FLAT_NAMES`]) moved into
/// their sections. Fails with [`Error::Config`] on a value that is not an
/// object, a name that is neither a section nor a flat name, or a field
/// given both ways.
pub fn nested(over: &Value) -> Result<Map<String, Value>, Error> {
    let Value::Object(over) = over else {
        return Err(Error::Config("expected a JSON object of configuration sections or fields".into()));
    };
    let mut out = Map::new();
    let mut flat = Vec::new();
    for (key, value) in over {
        if SECTIONS.contains(&key.as_str()) {
            out.insert(key.clone(), value.clone());
        } else if let Some(&(_, section, field)) = FLAT_NAMES.iter().find(|(flat, ..)| flat == key) {
            flat.push((section, field, value));
        } else {
            let within = FLAT_NAMES.iter().find(|(_, _, field)| field == key);
            let hint = within.map_or(String::new(), |(flat, section, field)| {
                format!(" (the field `{field}` of `{section}` is `{{\"{section}\": {{\"{field}\": …}}}}` or `{flat}`)")
            });
            return Err(Error::Config(format!(
                "unknown field `{key}`: expected a section ({}) or a field's flat name{hint}",
                SECTIONS.join(", ")
            )));
        }
    }
    for (section, field, value) in flat {
        let into = out.entry(section).or_insert_with(|| Value::Object(Map::new()));
        let Value::Object(into) = into else {
            return Err(Error::Config(format!("`{section}` must be an object of fields")));
        };
        if into.insert(field.to_string(), value.clone()).is_some() {
            return Err(Error::Config(format!("`{section}.{field}` is given twice, nested and flat")));
        }
    }
    Ok(out)
}
