//! The model and its deterministic local training (SPEC.md section 2).
//!
//! Placeholder: the learning issue fills this module in (`learn/`), with at least
//! `init_weights`, `train`, `loss`, `to_fixed` and `from_fixed`.
