//! How far ahead the driver speculates trainings: as far as speculations pay.
//!
//! A speculated training is used only if its robot's model is unchanged when its phase comes.
//! In the paper's rounds the model changes once a round, so most speculations of the window are
//! used; under the buffered protocol at 1000 robots a node's head changes every few seconds,
//! so a training speculated seconds ahead is mostly thrown away, and the wasted trainings take
//! the cores from the world and from the trainings that are due (issue 56: they made a
//! 1000-robot buffered run several times slower). The horizon therefore halves while fewer
//! than half of the recent speculations are used and doubles back while nearly all are, between
//! one tick (next tick's phases, trained while the driver steps the world) and the look-ahead
//! window. A performance choice only: the records never depend on what was speculated.

/// Speculations judged per adjustment of the horizon.
const JUDGED: u32 = 32;

/// The speculation horizon and the recent speculations' fate.
#[derive(Debug)]
pub(super) struct Horizon {
    max_ticks: u64,
    ticks: u64,
    used: u32,
    wasted: u32,
}

impl Horizon {
    /// A horizon of the whole look-ahead window of `max_ticks` ticks to start with.
    pub(super) fn new(max_ticks: u64) -> Horizon {
        Horizon {
            max_ticks,
            ticks: max_ticks,
            used: 0,
            wasted: 0,
        }
    }

    /// How many ticks ahead phases are speculated now.
    pub(super) fn ticks(&self) -> u64 {
        self.ticks
    }

    /// A speculation was used (`true`) or thrown away (`false`).
    pub(super) fn judge(&mut self, used: bool) {
        if used {
            self.used += 1;
        } else {
            self.wasted += 1;
        }
        let judged = self.used + self.wasted;
        if judged < JUDGED {
            return;
        }
        if 2 * self.used < judged {
            self.ticks = (self.ticks / 2).max(self.max_ticks.min(1));
        } else if 10 * self.used >= 9 * judged {
            self.ticks = (self.ticks * 2)
                .clamp(1, self.max_ticks.max(1))
                .min(self.max_ticks);
        }
        self.used = 0;
        self.wasted = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_horizon_shrinks_while_speculations_are_wasted_and_grows_back() {
        let mut h = Horizon::new(100);
        for _ in 0..JUDGED * 20 {
            h.judge(false);
        }
        assert_eq!(h.ticks(), 1, "down to next tick's phases, never to none");
        for _ in 0..JUDGED * 3 {
            h.judge(true);
        }
        assert_eq!(h.ticks(), 8);
        for _ in 0..JUDGED * 20 {
            h.judge(true);
        }
        assert_eq!(h.ticks(), 100, "never past the window");
        let mut none = Horizon::new(0);
        none.judge(true);
        for _ in 0..JUDGED * 2 {
            none.judge(true);
        }
        assert_eq!(none.ticks(), 0, "no window, no speculation");
    }
}
