//! The exit codes of `swarmfl`, and which errors map to which.

use swarmfl_core::log::LogError;
use swarmfl_core::replay::ReplayError;

/// Exit code for a run that is not bit-exact (divergence or damaged log).
pub const EXIT_DIVERGED: u8 = 1;
/// Exit code for bad arguments or input.
pub const EXIT_ERROR: u8 = 2;
/// Exit code of `diff --resimulate` when the log cannot be read: `git bisect run`'s "skip".
pub const EXIT_CANNOT_TEST: u8 = 125;

/// The exit code of a command that failed with `e`: 1 when a log is damaged or a run is not
/// bit-exact; 2 for bad arguments, missing files and foreign files.
pub fn of_error(e: &anyhow::Error) -> u8 {
    let diverged = matches!(
        e.downcast_ref::<ReplayError>(),
        Some(ReplayError::Diverged { .. } | ReplayError::Apply { .. })
            | Some(ReplayError::Log(
                LogError::Corrupt { .. } | LogError::Truncated { .. }
            ))
    );
    if diverged {
        EXIT_DIVERGED
    } else {
        EXIT_ERROR
    }
}
