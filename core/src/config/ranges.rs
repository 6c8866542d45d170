//! The range checks that every row of the validation table and the cross-key checks share:
//! one error shape (key, value, what is allowed) and one wording per kind of range, so that a
//! value refused by validation and one refused while an override is parsed (`overrides.rs`)
//! are told a range the same way.

use super::error::ConfigError;
use crate::types::show_f64;

/// Refuses `value` of `key`, saying what is `allowed` (and how to fix it).
pub(super) fn out_of_range(key: &str, value: String, allowed: String) -> Result<(), ConfigError> {
    Err(ConfigError::OutOfRange {
        key: key.to_string(),
        value,
        allowed,
    })
}

/// What a finite number in `[lo, hi]` is told.
pub(super) fn number_range(lo: f64, hi: f64) -> String {
    format!("a number in [{}, {}]", show_f64(lo), show_f64(hi))
}

/// What a finite number in `(0, hi]` is told.
pub(super) fn positive_range(hi: f64) -> String {
    format!("a number in (0, {}]", show_f64(hi))
}

/// What an integer in `[lo, hi]` is told.
pub(super) fn integer_range(lo: u64, hi: u64) -> String {
    format!("an integer in [{lo}, {hi}]")
}

/// `key`'s `value` is a finite number in `[lo, hi]`.
pub(super) fn number(key: &str, value: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        out_of_range(key, show_f64(value), number_range(lo, hi))
    }
}

/// `key`'s `value` is a finite number in `(0, hi]`.
pub(super) fn positive(key: &str, value: f64, hi: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value > 0.0 && value <= hi {
        Ok(())
    } else {
        out_of_range(key, show_f64(value), positive_range(hi))
    }
}

/// `key`'s `value` is an integer in `[lo, hi]`.
pub(super) fn integer(key: &str, value: u64, lo: u64, hi: u64) -> Result<(), ConfigError> {
    if value >= lo && value <= hi {
        Ok(())
    } else {
        out_of_range(key, value.to_string(), integer_range(lo, hi))
    }
}
