//! What can be wrong with a configuration.

/// What is wrong with a configuration, and how to fix it.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ConfigError {
    /// The preset name is not known.
    #[error("unknown preset {name:?}; the presets are: {allowed} (see `swarmfl presets`)")]
    UnknownPreset {
        /// The name given.
        name: String,
        /// The names allowed.
        allowed: String,
    },
    /// The configuration file could not be read.
    #[error("cannot read configuration file {path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// The TOML text is not valid or does not match the configuration tree.
    #[error("invalid configuration in {source_name}: {message}")]
    Parse {
        /// Where the text came from.
        source_name: String,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A key that does not exist.
    #[error("unknown configuration key `{key}`; {allowed} (see `swarmfl config`)")]
    UnknownKey {
        /// The key as given.
        key: String,
        /// `did you mean `x`?` when a key is close, then the keys allowed at that level.
        allowed: String,
    },
    /// A value of the wrong type.
    #[error("configuration key `{key}`: value `{value}` has the wrong type; expected {expected}")]
    WrongType {
        /// The key.
        key: String,
        /// The value as given.
        value: String,
        /// The expected type.
        expected: String,
    },
    /// A value that is not one of a key's choices (a typo of a rule or a kind).
    #[error("configuration key `{key}`: unknown value `{value}`{help}")]
    UnknownValue {
        /// The key.
        key: String,
        /// The value as given.
        value: String,
        /// `; did you mean `x`?` when one choice is close, then `; the choices are: ...` (one
        /// field, so the error stays as small as its other variants).
        help: String,
    },
    /// An entry of a list of tables (`faults.partitions`) that lacks a field, names an unknown
    /// one or holds a value of the wrong type.
    #[error("configuration key `{key}`: {problem}; {fix}")]
    BadEntry {
        /// The list's key.
        key: String,
        /// What is wrong with the entry.
        problem: String,
        /// How to write an entry (an example, or the fields).
        fix: String,
    },
    /// A value outside its allowed range.
    #[error("configuration key `{key}`: value {value} is out of range; allowed: {allowed}")]
    OutOfRange {
        /// The key.
        key: String,
        /// The value.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// A key that cannot change in the middle of a run (a fork's override).
    #[error("configuration key `{key}` cannot change in the middle of a run (it shapes the world, the model or the ledger from genesis); keys a fork may change: {allowed}")]
    NotReconfigurable {
        /// The key.
        key: String,
        /// The keys that may change.
        allowed: String,
    },
    /// A value the user did not set (it comes from the preset) that conflicts with the values
    /// they did set.
    #[error("{cause}; you did not set `{key}` (preset `{preset}` gives it), but it no longer fits what you set ({set}): set `{key}` too, or change those values")]
    NotSetByYou {
        /// The preset's key that is out of range.
        key: String,
        /// The preset it came from.
        preset: String,
        /// The keys the user set, comma-separated.
        set: String,
        /// The range error. (Not `source`: the message already holds it, and an error chain
        /// printer such as anyhow's would print it a second time.)
        cause: Box<ConfigError>,
    },
    /// A `--set` argument that is not `key=value`.
    #[error("invalid override `{assignment}`: {message}")]
    Override {
        /// The argument.
        assignment: String,
        /// What is wrong.
        message: String,
    },
}
