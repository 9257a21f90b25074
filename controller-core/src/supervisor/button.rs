//! The arm button: debouncing and press classification, one raw sample per control step.

/// What the debounced button did in one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Press {
    /// A press began (debounced).
    Down,
    /// The press has lasted `long_press_steps`.
    Long,
    /// The press ended (debounced); `long` if it reached `long_press_steps`.
    Up {
        /// The press lasted at least `long_press_steps`.
        long: bool,
    },
}

/// Debounces a raw button level sampled once per step.
#[derive(Clone, Copy, Debug)]
pub(super) struct Debouncer {
    /// Debounced level.
    pressed: bool,
    /// Steps the raw level has differed from `pressed`.
    changing_steps: u32,
    /// Steps the debounced press has lasted.
    held_steps: u32,
}

impl Debouncer {
    pub(super) const fn new() -> Self {
        Self {
            pressed: false,
            changing_steps: 0,
            held_steps: 0,
        }
    }

    /// The debounced level: true while pressed.
    pub(super) const fn pressed(&self) -> bool {
        self.pressed
    }

    /// One raw sample `raw` (true while pressed). A change counts once the raw level has
    /// differed from the debounced one for `debounce_steps` consecutive samples.
    pub(super) fn update(
        &mut self,
        raw: bool,
        debounce_steps: u32,
        long_press_steps: u32,
    ) -> Option<Press> {
        if raw == self.pressed {
            self.changing_steps = 0;
        } else {
            self.changing_steps = self.changing_steps.saturating_add(1);
            if self.changing_steps >= debounce_steps {
                self.changing_steps = 0;
                self.pressed = raw;
                if raw {
                    // The press began `debounce_steps` ago.
                    self.held_steps = debounce_steps;
                    return Some(Press::Down);
                }
                return Some(Press::Up {
                    long: self.held_steps >= long_press_steps,
                });
            }
        }
        if self.pressed {
            let before = self.held_steps;
            self.held_steps = self.held_steps.saturating_add(1);
            if before < long_press_steps && self.held_steps >= long_press_steps {
                return Some(Press::Long);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `levels` (one per step) and returns every press event with its step index.
    fn events(levels: impl IntoIterator<Item = bool>) -> Vec<(usize, Press)> {
        let mut d = Debouncer::new();
        levels
            .into_iter()
            .enumerate()
            .filter_map(|(k, raw)| d.update(raw, 20, 1000).map(|p| (k, p)))
            .collect()
    }

    #[test]
    fn a_10_ms_bounce_is_not_a_press() {
        // 10 steps down, 10 up, repeated: never 20 consecutive steps pressed.
        let levels = (0..400).map(|k| (k / 10) % 2 == 0);
        assert_eq!(events(levels), vec![]);
    }

    #[test]
    fn a_press_counts_after_exactly_the_debounce_time() {
        // Pressed from step 0: the 20th sample (index 19) makes it a press; released at
        // step 100: the 20th released sample (index 119) ends it.
        let levels = (0..200).map(|k| k < 100);
        assert_eq!(
            events(levels),
            vec![(19, Press::Down), (119, Press::Up { long: false })]
        );
        // 19 steps is one too few.
        assert_eq!(events((0..100).map(|k| k < 19)), vec![]);
    }

    #[test]
    fn a_held_press_becomes_long_once() {
        let levels = (0..2000).map(|k| k < 1500);
        let got = events(levels);
        // Down at 19 (held counted from the press's start), long when 1000 steps held
        // (index 999), up when released.
        assert_eq!(
            got,
            vec![
                (19, Press::Down),
                (999, Press::Long),
                (1519, Press::Up { long: true })
            ]
        );
    }

    #[test]
    fn a_glitch_during_a_press_restarts_the_release_count() {
        // Released for 15 steps (a bounce) in the middle of a press: still one press.
        let levels = (0..300).map(|k| k < 100 || (115..200).contains(&k));
        assert_eq!(
            events(levels),
            vec![(19, Press::Down), (219, Press::Up { long: false })]
        );
    }
}
