//! A warning reported once a spell: the low battery, a failed gyro, a gyro that
//! disagrees with odometry.
//!
//! Contract: while a warning's condition lasts (its spell), [`OncePerSpell::due`] is true
//! in exactly one step, the first in which the step's one event slot is free; a step
//! without the condition ends the spell. So a warning is delayed by another event, never
//! lost, and never repeated within a spell.

/// One warning's latch (module doc).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct OncePerSpell {
    /// Reported in the present spell.
    reported: bool,
}

impl OncePerSpell {
    /// True in the step that reports the warning: its condition `active`, not yet
    /// reported this spell, and the event slot `slot_free`.
    pub(super) fn due(&mut self, active: bool, slot_free: bool) -> bool {
        self.reported &= active;
        let due = active && slot_free && !self.reported;
        self.reported |= due;
        due
    }

    /// Ends the spell: the next step with the condition reports it again.
    pub(super) fn restart(&mut self) {
        self.reported = false;
    }
}

#[cfg(test)]
mod tests {
    use super::OncePerSpell;

    #[test]
    fn once_a_spell_in_the_first_free_step() {
        let mut w = OncePerSpell::default();
        assert!(!w.due(false, true));
        assert!(!w.due(true, false), "the slot is taken: later");
        assert!(w.due(true, true));
        assert!(!w.due(true, true), "once a spell");
        assert!(!w.due(false, true));
        assert!(w.due(true, true), "a new spell");
        w.restart();
        assert!(w.due(true, true), "restarted");
    }
}
