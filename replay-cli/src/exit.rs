//! The exit codes of `swarmfl`, and which errors map to which.

use swarmfl_core::inspect::InspectError;
use swarmfl_core::log::LogError;
use swarmfl_core::replay::ReplayError;

/// Exit code for a run that is not bit-exact (divergence or damaged log).
pub const EXIT_DIVERGED: u8 = 1;
/// Exit code for bad arguments or input.
pub const EXIT_ERROR: u8 = 2;
/// Exit code of `diff --resimulate` when the log cannot be read: `git bisect run`'s "skip".
pub const EXIT_CANNOT_TEST: u8 = 125;

/// The exit code of a command that failed with `e`: 1 when a log is damaged or a run is not
/// bit-exact; 2 for bad arguments, missing files and foreign files. The same damage gives the
/// same code whichever command met it (`replay`, `inspect`, `view`, ...): the log error is
/// looked for through `inspect`'s error and any context around it.
pub fn of_error(e: &anyhow::Error) -> u8 {
    if e.chain().any(is_divergence) {
        EXIT_DIVERGED
    } else {
        EXIT_ERROR
    }
}

/// A damaged log or a run that is not bit-exact, as any command reports it.
fn is_divergence(e: &(dyn std::error::Error + 'static)) -> bool {
    let replay =
        e.downcast_ref::<ReplayError>()
            .or_else(|| match e.downcast_ref::<InspectError>() {
                Some(InspectError::Replay(r)) => Some(r),
                _ => None,
            });
    let log = e.downcast_ref::<LogError>().or(match replay {
        Some(ReplayError::Log(l)) => Some(l),
        _ => None,
    });
    matches!(
        replay,
        Some(ReplayError::Diverged { .. } | ReplayError::Apply { .. })
    ) || matches!(
        log,
        Some(LogError::Corrupt { .. } | LogError::Truncated { .. })
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_damaged_log_is_exit_1_whichever_command_met_it() {
        let corrupt = || LogError::Corrupt {
            path: "r.swlog".into(),
            offset: 40,
            index: 3,
            message: "frame header check failed".into(),
            last_good_checkpoint: None,
        };
        let via_replay = anyhow::Error::from(ReplayError::from(corrupt()));
        let via_inspect = anyhow::Error::from(InspectError::from(ReplayError::from(corrupt())));
        let with_context = via_inspect.context("inspect r.swlog");
        let bare = anyhow::Error::from(corrupt());
        for e in [&via_replay, &with_context, &bare] {
            assert_eq!(of_error(e), EXIT_DIVERGED, "{e:#}");
        }
        let foreign =
            anyhow::Error::from(InspectError::from(ReplayError::from(LogError::NotALog {
                path: "x".into(),
            })));
        assert_eq!(of_error(&foreign), EXIT_ERROR);
    }
}
