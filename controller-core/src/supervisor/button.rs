//! The arm button: debouncing and press classification, one raw sample per control step.
//!
//! A press is short (released before `long_press_steps`), long (released after it), or
//! held on to [`MODE_SELECT_FACTOR`] × `long_press_steps`, which the debouncer reports
//! while the button is still down.

/// A press held this many times `long_press_steps` selects the run mode (3 s with the
/// default 1 s long press).
pub const MODE_SELECT_FACTOR: u32 = 3;

/// How long a released press lasted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Length {
    /// Released before `long_press_steps`.
    Short,
    /// Released after `long_press_steps`, before the mode-select hold.
    Long,
    /// Held to [`MODE_SELECT_FACTOR`] × `long_press_steps` or beyond.
    ModeSelect,
}

/// What the debounced button did in one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Press {
    /// A press began (debounced).
    Down,
    /// The press has lasted [`MODE_SELECT_FACTOR`] × `long_press_steps` (reported once,
    /// while the button is still down).
    ModeSelectHeld,
    /// The press ended (debounced), after lasting this long.
    Up(Length),
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
    /// differed from the debounced one for `debounce_steps` consecutive samples; a press
    /// is long from `long_press_steps` on.
    pub(super) fn update(
        &mut self,
        raw: bool,
        debounce_steps: u32,
        long_press_steps: u32,
    ) -> Option<Press> {
        let mode_select_steps = long_press_steps.saturating_mul(MODE_SELECT_FACTOR);
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
                let length = if self.held_steps >= mode_select_steps {
                    Length::ModeSelect
                } else if self.held_steps >= long_press_steps {
                    Length::Long
                } else {
                    Length::Short
                };
                return Some(Press::Up(length));
            }
        }
        if self.pressed {
            let before = self.held_steps;
            self.held_steps = self.held_steps.saturating_add(1);
            if before < mode_select_steps && self.held_steps >= mode_select_steps {
                return Some(Press::ModeSelectHeld);
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
            vec![(19, Press::Down), (119, Press::Up(Length::Short))]
        );
        // 19 steps is one too few.
        assert_eq!(events((0..100).map(|k| k < 19)), vec![]);
    }

    #[test]
    fn a_press_is_long_from_the_long_press_time_and_selects_at_three_times_it() {
        // Down at 19 (held counted from the press's start); released after 1.5 s: long.
        assert_eq!(
            events((0..2000).map(|k| k < 1500)),
            vec![(19, Press::Down), (1519, Press::Up(Length::Long))]
        );
        // Released at 0.9 s (0.92 s with the release's debounce): short.
        assert_eq!(
            events((0..2000).map(|k| k < 900)),
            vec![(19, Press::Down), (919, Press::Up(Length::Short))]
        );
        // Held on: the mode-select hold is reported once when 3000 steps are held (index
        // 2999), while still down, and the release says so again.
        assert_eq!(
            events((0..5000).map(|k| k < 4000)),
            vec![
                (19, Press::Down),
                (2999, Press::ModeSelectHeld),
                (4019, Press::Up(Length::ModeSelect))
            ]
        );
    }

    #[test]
    fn a_glitch_during_a_press_restarts_the_release_count() {
        // Released for 15 steps (a bounce) in the middle of a press: still one press.
        let levels = (0..300).map(|k| k < 100 || (115..200).contains(&k));
        assert_eq!(
            events(levels),
            vec![(19, Press::Down), (219, Press::Up(Length::Short))]
        );
    }
}
