//! Which keys the serialised configuration leaves out: keys added after records existed stay
//! out of the recorded text at their default, never out of the full tree that `swarmfl config`
//! prints and `--set` walks. A leaf of `config`, so `tree` and `preagg` both use it.

thread_local! {
    /// Set while [`with_every_key`] serialises: no key is left out.
    static EVERY_KEY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Serialises with `f` while every `skip_serializing_if` of the configuration answers "keep":
/// the full tree that `swarmfl config` prints and `--set` walks, by the same serde code as the
/// recorded text, so a key added with a default left out of records is never missing from it.
pub(super) fn with_every_key<T>(f: impl FnOnce() -> T) -> T {
    struct Reset;
    impl Drop for Reset {
        fn drop(&mut self) {
            EVERY_KEY.with(|k| k.set(false));
        }
    }
    EVERY_KEY.with(|k| k.set(true));
    let _reset = Reset;
    f()
}

/// Whether a key at its default is left out of the serialised text: keys added after records
/// existed stay out of the recorded text while unused (see `Config::to_toml`), but never out
/// of [`with_every_key`]'s.
pub(super) fn omit(at_default: bool) -> bool {
    at_default && !EVERY_KEY.with(std::cell::Cell::get)
}
