//! Property tests of the configuration's input paths: arbitrary `--set` arguments and arbitrary
//! TOML text never panic, and every error names the key, the argument or the file.

use proptest::prelude::*;
use swarmfl_core::config::{Config, ConfigError, Preset};

const SOURCE: &str = "props.toml";

/// Keys that exist, a few that almost do, and junk.
fn key() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => prop::sample::select(vec![
            "preset", "run.duration_s", "run.tick_s", "world.robots", "world.rab_range_m",
            "world.arena_side_m", "learn.dropout", "byzantine.kind", "byzantine.count",
            "contract", "world", "ledger", "data",
        ])
        .prop_map(str::to_string),
        1 => "[a-z_.]{0,20}",
        1 => ".{0,20}",
    ]
}

/// Values of every TOML type, near and past the ranges, and junk.
fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<i64>().prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| format!("{v:?}")),
        prop::sample::select(vec![
            "nan",
            "inf",
            "-inf",
            "true",
            "false",
            "\"faulty\"",
            "malicious",
            "[1, 1, -1]",
            "{}",
            "{ robots = 3 }",
            "[",
            "\"",
            "0",
            "-1",
            "1e400",
            "4294967296",
            "1979-05-27T07:32:00Z",
            "\"../../etc\"",
            "smoke",
        ])
        .prop_map(str::to_string),
        ".{0,30}",
    ]
}

fn assignment() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (key(), " {0,2}", value()).prop_map(|(k, s, v)| format!("{k}{s}={s}{v}")),
        1 => ".{0,40}",
    ]
}

/// TOML-like text: sections and lines built from the keys and values above, or junk.
fn toml_text() -> impl Strategy<Value = String> {
    let line = prop_oneof![
        (key(), value()).prop_map(|(k, v)| match k.rsplit_once('.') {
            Some((section, field)) => format!("[{section}]\n{field} = {v}"),
            None => format!("{k} = {v}"),
        }),
        "\\[[a-z]{0,8}\\]",
        ".{0,30}",
    ];
    prop_oneof![
        4 => prop::collection::vec(line, 0..6).prop_map(|lines| lines.join("\n")),
        1 => any::<Vec<u8>>().prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn set_never_panics_and_errors_name_the_key(assignments in prop::collection::vec(assignment(), 1..4)) {
        let mut config = Preset::Smoke.config();
        for a in &assignments {
            // Compared as text: a NaN set earlier is not equal to itself.
            let before = config.to_toml();
            match config.set(a) {
                Ok(()) => {
                    // An accepted value keeps the tree serialisable.
                    let text = config.to_toml();
                    prop_assert!(text.contains("[world]"));
                }
                Err(e) => {
                    prop_assert_eq!(config.to_toml(), before, "a failed set changed the config");
                    let message = e.to_string();
                    let named = match a.split_once('=') {
                        Some((k, _)) => message.contains(k.trim()),
                        None => matches!(e, ConfigError::Override { .. }) && message.contains(a.as_str()),
                    };
                    prop_assert!(named, "error for `{}` does not name it: {}", a, message);
                }
            }
        }
        if let Err(e) = config.validate() {
            let message = e.to_string();
            prop_assert!(matches!(e, ConfigError::OutOfRange { .. }), "{}", message);
            prop_assert!(message.starts_with("configuration key `"), "{}", message);
        }
    }

    #[test]
    fn resolve_with_overrides_never_panics(assignments in prop::collection::vec(assignment(), 0..4)) {
        match Config::resolve(Some("smoke"), None, &assignments) {
            Ok(config) => prop_assert!(config.validate().is_ok()),
            Err(e) => {
                let message = e.to_string();
                let named = assignments.iter().any(|a| {
                    message.contains(a.split_once('=').map_or(a.as_str(), |(k, _)| k.trim()))
                }) || matches!(e, ConfigError::OutOfRange { .. });
                prop_assert!(named, "{}", message);
            }
        }
    }

    #[test]
    fn toml_text_never_panics_and_errors_name_the_file_or_key(text in toml_text()) {
        match Config::from_toml_str(&text, SOURCE) {
            Ok(config) => {
                prop_assert!(config.validate().is_ok());
                let back = Config::from_toml_str(&config.to_toml(), SOURCE).unwrap();
                prop_assert_eq!(back, config);
            }
            Err(e) => {
                let message = e.to_string();
                let named = match &e {
                    ConfigError::Parse { source_name, .. } => source_name == SOURCE,
                    ConfigError::UnknownKey { key, .. }
                    | ConfigError::WrongType { key, .. }
                    | ConfigError::UnknownValue { key, .. }
                    | ConfigError::BadEntry { key, .. } => {
                        key.ends_with(&format!("(in {SOURCE})"))
                    }
                    ConfigError::OutOfRange { .. } => message.starts_with("configuration key `"),
                    ConfigError::NotSetByYou { key, .. } => message.contains(key.as_str()),
                    ConfigError::UnknownPreset { name, .. } => message.contains(&format!("{name:?}")),
                    ConfigError::Io { .. }
                    | ConfigError::Override { .. }
                    | ConfigError::NotReconfigurable { .. } => false,
                };
                prop_assert!(named, "{:?} gives an error naming neither file nor key: {}", text, message);
            }
        }
    }
}
