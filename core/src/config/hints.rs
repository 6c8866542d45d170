//! What the configuration's error messages suggest: the nearest key or choice, an example value
//! for each list key, serde's type names in the user's words, and numbers written compactly.
//! Only messages read these: nothing here reaches a record. (Numbers are written by
//! [`crate::types::show_f64`], which the fault checks below the configuration share.)

/// The choice nearest to `given` (case-insensitive), if one is within a third of its length
/// (at least 1 edit, at most 3): a typo, not another word.
pub(super) fn nearest<'a>(
    given: &str,
    choices: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let lowered = given.to_ascii_lowercase();
    choices
        .into_iter()
        .map(|c| (strsim::levenshtein(&lowered, c), c))
        .min()
        .filter(|(d, c)| *d <= (c.len() / 3).clamp(1, 3))
        .map(|(_, c)| c)
}

/// The dotted key nearest to `key` among `keys` (every key of the configuration): a typo of
/// the field or of its table (`world.robotz`, `wrld.robots`), else the one key whose last part
/// is `key`'s last part (`robots` for `world.robots`).
pub(super) fn nearest_key<'a>(key: &str, keys: &'a [String]) -> Option<&'a str> {
    if let Some(k) = nearest(key, keys.iter().map(String::as_str)) {
        return Some(k);
    }
    let last = key.rsplit('.').next().unwrap_or(key);
    let mut same = keys
        .iter()
        .filter(|k| k.rsplit('.').next() == Some(last) && k.as_str() != key);
    match (same.next(), same.next()) {
        (Some(k), None) => Some(k),
        _ => None,
    }
}

/// Every dotted key of `tree` whose value is not a table (`world.robots`, `faults.partitions`),
/// sorted.
pub(super) fn dotted_keys(tree: &toml::Value) -> Vec<String> {
    super::tree::toml_leaves(tree).into_keys().collect()
}

/// An example value of each list key, as `--set` takes it (checked by a test: each one is
/// accepted).
pub(super) fn list_example(key: &str) -> Option<&'static str> {
    Some(match key {
        "faults.partitions" => r#"[{kind = "split", start_s = 10, end_s = 20}]"#,
        "faults.loss_bursts" => "[{loss = 0.5, start_s = 10, end_s = 20}]",
        "faults.delays" => "[{extra_ms = 200, start_s = 10, end_s = 20}]",
        "faults.crashes" => "[{robot = 0, start_s = 10, end_s = 20}]",
        "faults.clock_skews" => "[{robot = 0, skew_ms = 500}]",
        "contract.preaggregators" => r#"["nnm"]"#,
        "contract.reward_weights" => "[1, 1, -1]",
        "world.mixed.per_robot" => r#"["avoidance", "flocking"]"#,
        "learn.withheld" | "byzantine.as_honest" => "[0, 3]",
        _ => return None,
    })
}

/// What a list key takes: `an array, e.g. ...` with its example.
pub(super) fn list_expected(key: &str) -> String {
    match list_example(key) {
        Some(e) if e.starts_with("[{") => {
            format!("an array of tables, e.g. --set '{key}={e}'")
        }
        Some(e) => format!("an array, e.g. --set '{key}={e}'"),
        None => "an array".to_string(),
    }
}

/// The keys whose number may also be `"inf"` (read as infinity by `overrides::coerce`).
const INF_KEYS: [&str; 1] = ["world.home_range.alpha"];

/// What a number key takes: `a number`, or for a key that may be infinite, `a positive
/// number or "inf"` with an example.
pub(super) fn number_expected(key: &str) -> String {
    if INF_KEYS.contains(&key) {
        format!("a positive number or \"inf\" (e.g. --set {key}=0.1, or {key}=inf for none)")
    } else {
        "a number".to_string()
    }
}

/// serde's name of an expected type (`u32`, `f64`, `a boolean`) in the user's words.
pub(super) fn type_in_words(expected: &str) -> String {
    let whole = |max: u64| format!("a whole number from 0 to {max}");
    let signed = |min: i64, max: i64| format!("an integer from {min} to {max}");
    match expected {
        "u8" => whole(u8::MAX.into()),
        "u16" => whole(u16::MAX.into()),
        "u32" => whole(u32::MAX.into()),
        "u64" | "usize" => whole(u64::MAX),
        "i8" => signed(i8::MIN.into(), i8::MAX.into()),
        "i16" => signed(i16::MIN.into(), i16::MAX.into()),
        "i32" => signed(i32::MIN.into(), i32::MAX.into()),
        "i64" | "isize" => signed(i64::MIN, i64::MAX),
        "f32" | "f64" => "a number".to_string(),
        "a boolean" => "true or false".to_string(),
        "a sequence" => "an array".to_string(),
        "a map" => "a table".to_string(),
        e if e.starts_with("struct ") => "a table".to_string(),
        e => e.to_string(),
    }
}

/// What serde said about a value, split into the parts a message uses.
#[derive(Debug, PartialEq)]
pub(super) enum SerdeMessage<'a> {
    /// `invalid value: integer `-3`, expected u32`: (the value, the type).
    InvalidValue(&'a str, &'a str),
    /// `invalid type: string "x", expected f64`: (what was given, the type).
    InvalidType(&'a str, &'a str),
    /// `missing field `end_s``.
    MissingField(&'a str),
    /// `unknown field `x`, expected one of `a`, `b``: (the field, the fields).
    UnknownField(&'a str, Vec<&'a str>),
    /// Anything else.
    Other(&'a str),
}

/// Reads serde's message (toml's `Error::message`).
pub(super) fn read_serde(message: &str) -> SerdeMessage<'_> {
    let message = message.trim();
    if let Some(rest) = message.strip_prefix("invalid value: ") {
        if let Some((value, expected)) = rest.rsplit_once(", expected ") {
            let value = value
                .split_once('`')
                .map_or(value, |(_, v)| v.trim_end_matches('`'));
            return SerdeMessage::InvalidValue(value, expected);
        }
    }
    if let Some(rest) = message.strip_prefix("invalid type: ") {
        if let Some((given, expected)) = rest.rsplit_once(", expected ") {
            return SerdeMessage::InvalidType(given, expected);
        }
    }
    if let Some(rest) = message.strip_prefix("missing field `") {
        return SerdeMessage::MissingField(rest.trim_end_matches('`'));
    }
    if let Some(rest) = message.strip_prefix("unknown field `") {
        if let Some((field, list)) = rest.split_once('`') {
            let fields = list
                .trim_start_matches(", expected one of ")
                .trim_start_matches(", expected ")
                .split(", ")
                .map(|c| c.trim().trim_start_matches("or ").trim_matches('`'))
                .filter(|c| !c.is_empty())
                .collect();
            return SerdeMessage::UnknownField(field, fields);
        }
    }
    SerdeMessage::Other(message)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_messages_are_read() {
        assert_eq!(
            read_serde("invalid value: integer `-3`, expected u32"),
            SerdeMessage::InvalidValue("-3", "u32")
        );
        assert_eq!(
            read_serde("missing field `end_s`"),
            SerdeMessage::MissingField("end_s")
        );
        assert_eq!(
            read_serde("unknown field `ends`, expected one of `kind`, `robot`, `end_s`"),
            SerdeMessage::UnknownField("ends", vec!["kind", "robot", "end_s"])
        );
        assert_eq!(type_in_words("u32"), "a whole number from 0 to 4294967295");
    }

    #[test]
    fn the_nearest_key_is_a_typo_or_the_same_field_elsewhere() {
        let keys: Vec<String> = ["world.robots", "world.boxes", "run.duration_s"]
            .map(String::from)
            .to_vec();
        assert_eq!(nearest_key("world.robotz", &keys), Some("world.robots"));
        assert_eq!(nearest_key("wrld.robots", &keys), Some("world.robots"));
        assert_eq!(nearest_key("robots", &keys), Some("world.robots"));
        assert_eq!(nearest_key("learn.speed", &keys), None);
    }
}
