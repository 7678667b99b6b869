//! Why a training configuration is refused ([`ConfigError`]).

/// Why a training configuration is refused: the field at fault and the
/// range or rule it breaks, or what in a `--config` object is not a
/// configuration.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// A field out of its range or against a rule (its message starts with the field).
    #[error("{field} {rule}")]
    Invalid {
        /// The field at fault, `section.field` (the first one the rule names).
        field: &'static str,
        /// What follows the field in the message: its value where shown,
        /// then the range or rule it breaks (`must be 1..=256`).
        rule: String,
    },
    /// A rule over several fields, stated whole (its message does not start with a field).
    #[error("{rule}")]
    Combination {
        /// The fields the rule ties together, `section.field`.
        fields: &'static [&'static str],
        /// The rule, as the message states it.
        rule: &'static str,
    },
    /// A configuration the proposal grid `nerf train` gives a scene cannot serve.
    #[error(
        "invalid configuration: {source} (the proposal grid this {kind} scene gets; set sampling.proposal_res 0 \
         with --config to train it with the occupancy grid instead)"
    )]
    ProposalGrid {
        /// The scene's kind (`forward-facing`, `unbounded`).
        kind: &'static str,
        /// The rule the configuration with the grid breaks.
        #[source]
        source: Box<ConfigError>,
    },
    /// A `--config` value that is not a JSON object.
    #[error("expected a JSON object of configuration sections or fields")]
    NotAnObject,
    /// A name that is neither a section nor a field's flat name.
    #[error(
        "unknown field `{name}`: expected a section ({}) or a field's flat name{}",
        .sections.join(", "),
        within_hint(.within)
    )]
    UnknownName {
        /// The name as given.
        name: String,
        /// The configuration's sections.
        sections: &'static [&'static str],
        /// The field of that name within a section, if there is one.
        within: Option<FlatName>,
    },
    /// A section given as something other than an object of fields.
    #[error("`{section}` must be an object of fields")]
    NotASection {
        /// The section.
        section: String,
    },
    /// A section this build does not have.
    #[error("unknown section `{section}`")]
    UnknownSection {
        /// The section as given.
        section: String,
    },
    /// A field given both nested in its section and by its flat name.
    #[error("`{section}.{field}` is given twice, nested and flat")]
    Twice {
        /// The field's section.
        section: &'static str,
        /// The field's name in the section.
        field: String,
    },
    /// A field named at the place it has moved from.
    #[error(
        "`{from}` is `{to}` (`{{\"{}\": {{\"{}\": …}}}}`, or by its flat name `{flat}`)",
        section_and_field(.to).0,
        section_and_field(.to).1
    )]
    Moved {
        /// Where it was, `section.field`.
        from: String,
        /// Where it is, `section.field`.
        to: &'static str,
        /// Its flat name.
        flat: String,
    },
    /// A field's value of the wrong type: the field and serde_json's reason.
    #[error("`{field}`: {source}")]
    Value {
        /// The field, `section.field`.
        field: String,
        /// Why serde_json cannot read the value as the field's.
        #[source]
        source: serde_json::Error,
    },
    /// The configuration cannot be turned into JSON or read back from it.
    #[error("{0}")]
    Json(#[source] serde_json::Error),
}

impl ConfigError {
    /// A field out of its range or against a rule: `field` and what
    /// follows it in the message.
    pub fn invalid(field: &'static str, rule: impl Into<String>) -> Self {
        ConfigError::Invalid { field, rule: rule.into() }
    }
}

/// The hint of [`ConfigError::UnknownName`]: how to name the field of that
/// name within a section.
fn within_hint(within: &Option<FlatName>) -> String {
    within.as_ref().map_or(String::new(), |FlatName { flat, section, field }| {
        format!(" (the field `{field}` of `{section}` is `{{\"{section}\": {{\"{field}\": …}}}}` or `{flat}`)")
    })
}

/// `section.field` as its section and field (the whole as the section
/// without a dot).
fn section_and_field(path: &str) -> (&str, &str) {
    path.split_once('.').unwrap_or((path, ""))
}

/// One configuration field's names: its flat name (a `--config` file
/// without sections), its section and its name there.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FlatName {
    /// The name without a section.
    pub flat: String,
    /// Its section, one of `config::json::SECTIONS`.
    pub section: &'static str,
    /// Its name in the section.
    pub field: String,
}
