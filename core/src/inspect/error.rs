//! Why a look into a run failed.

use super::expr::EvalError;
use crate::replay::ReplayError;
use crate::types::{RobotId, SimTime};

/// Why a look into a run failed.
#[derive(Debug, thiserror::Error)]
pub enum InspectError {
    /// The log cannot be read or folded.
    #[error(transparent)]
    Replay(#[from] ReplayError),
    /// The block asked for is beyond the final canonical chain.
    #[error("{path}: there is no block {block} on the final canonical chain; its last block is at height {last}")]
    BlockPastEnd {
        /// The log.
        path: String,
        /// The height asked for.
        block: u64,
        /// The last height.
        last: u64,
    },
    /// The robot asked for is not in the swarm.
    #[error("there is no robot {robot}: the swarm has robots 0 to {}", robots.saturating_sub(1))]
    NoRobot {
        /// The id asked for.
        robot: RobotId,
        /// The swarm size.
        robots: u32,
    },
    /// The log's blocks do not fit together (a damaged or foreign log).
    #[error("{path}: {message}")]
    Inconsistent {
        /// The log.
        path: String,
        /// What does not fit.
        message: String,
    },
    /// A sampling period that is zero or longer than any run.
    #[error("a period of {period} cannot sample a run: give one from 0.001 s to {max}")]
    Period {
        /// The period asked for.
        period: SimTime,
        /// The longest accepted.
        max: SimTime,
    },
    /// A predicate names a value the state does not have.
    #[error("cannot evaluate the expression at block {block}: {cause}")]
    Eval {
        /// The block.
        block: u64,
        /// What is wrong.
        cause: EvalError,
    },
}
