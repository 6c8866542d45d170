#![no_main]
//! Fuzzes the configuration parser. The first input byte picks the mode:
//!
//! - file: the rest is the text of a configuration file, given to `Config::from_toml_str`;
//! - overrides: the rest is a list of `--set` arguments, one a line, applied with `Config::set`
//!   to a preset.
//!
//! Nothing may panic; every error must name a key, the source or the argument; a configuration
//! that is accepted must serialise, validate and parse back to itself.

use libfuzzer_sys::fuzz_target;
use swarmfl_core::config::{Config, ConfigError, Preset};

const SOURCE: &str = "fuzz.toml";

fn accepted(config: &Config) {
    let text = config.to_toml();
    let back = Config::from_toml_str(&text, SOURCE);
    if config.validate().is_ok() {
        let back =
            back.unwrap_or_else(|e| panic!("a valid config does not parse back: {e}\n{text}"));
        // Floats print in TOML as they parse, so the round trip is exact (NaN aside).
        if back.to_toml() != text {
            panic!(
                "round trip changed the config:\n{text}\n---\n{}",
                back.to_toml()
            );
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let text = String::from_utf8_lossy(rest);
    if mode % 2 == 0 {
        match Config::from_toml_str(&text, SOURCE) {
            Ok(config) => accepted(&config),
            Err(e) => {
                let message = e.to_string();
                let named = match &e {
                    ConfigError::Parse { source_name, .. } => source_name == SOURCE,
                    ConfigError::UnknownKey { key, .. }
                    | ConfigError::WrongType { key, .. }
                    | ConfigError::UnknownValue { key, .. }
                    | ConfigError::BadEntry { key, .. } => key.contains(SOURCE),
                    ConfigError::OutOfRange { key, .. } => !key.is_empty(),
                    ConfigError::NotSetByYou { key, .. }
                    | ConfigError::NotReconfigurable { key, .. } => {
                        !key.is_empty() && message.contains(key.as_str())
                    }
                    ConfigError::UnknownPreset { name, .. } => message.contains(name.as_str()),
                    ConfigError::Io { .. } | ConfigError::Override { .. } => false,
                };
                assert!(named, "error names neither the file nor a key: {message}");
            }
        }
    } else {
        let presets = Preset::ALL;
        let mut config = presets[usize::from(mode / 2) % presets.len()].config();
        for line in text.lines() {
            match config.set(line) {
                Ok(()) => accepted(&config),
                Err(e) => {
                    let message = e.to_string();
                    let key = line.split_once('=').map(|(k, _)| k.trim());
                    let named = match key {
                        Some(k) => {
                            message.contains(k) || matches!(e, ConfigError::UnknownKey { .. })
                        }
                        None => message.contains(line),
                    };
                    assert!(
                        named,
                        "error for `{line}` names neither the key nor the argument: {message}"
                    );
                }
            }
        }
    }
});
