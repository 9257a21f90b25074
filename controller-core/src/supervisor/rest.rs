//! Whether the wheels are at rest, for arming: a robot armed while its wheels still turn
//! (a second press that comes before they have stopped) would start the run from a
//! motion it does not know about, so arming waits for rest unless the request asserts
//! the motion ([`super::ArmRequest::initial_motion`]).

use crate::kinematics::WheelSpeeds;
use crate::math;

/// Both measured wheel speeds below this count as at rest, rad/s (≈ 1.6 cm/s of rim
/// speed on the reference robot's 32.5 mm wheels; a still wheel whose encoder flickers
/// by one tick reads 0.22 rad/s there).
pub const REST_SPEED_RAD_S: f32 = 0.5;

/// Consecutive control steps at rest arming needs (100 ms at 1 kHz). Longer than the
/// longest speed window (64 steps), so that an estimate refilling after a reset of its
/// history cannot pass for rest while the wheel turns.
pub const REST_STEPS: u32 = 100;

/// Counts the consecutive steps both measured wheel speeds were at rest.
#[derive(Clone, Copy, Debug)]
pub(super) struct AtRest {
    steps: u32,
}

impl AtRest {
    /// At rest from the start: no wheel has been seen turning since the reset.
    pub(super) const fn new() -> Self {
        Self { steps: REST_STEPS }
    }

    /// One step whose measured wheel speeds (rad/s) were `speeds`.
    pub(super) fn update(&mut self, speeds: WheelSpeeds) {
        let still = math::abs(speeds.left_rad_s) < REST_SPEED_RAD_S
            && math::abs(speeds.right_rad_s) < REST_SPEED_RAD_S;
        self.steps = if still {
            self.steps.saturating_add(1)
        } else {
            0
        };
    }

    /// True once both wheels have been at rest for [`REST_STEPS`] steps in a row.
    pub(super) const fn at_rest(&self) -> bool {
        self.steps >= REST_STEPS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rest_needs_both_wheels_still_for_the_whole_count() {
        let mut rest = AtRest::new();
        assert!(rest.at_rest(), "nothing has turned since the reset");
        rest.update(WheelSpeeds::new(0.0, -0.6));
        assert!(!rest.at_rest());
        for _ in 0..REST_STEPS - 1 {
            rest.update(WheelSpeeds::new(0.49, -0.49));
        }
        assert!(!rest.at_rest(), "one step short");
        rest.update(WheelSpeeds::new(0.0, 0.0));
        assert!(rest.at_rest());
        rest.update(WheelSpeeds::new(f32::NAN, 0.0));
        assert!(!rest.at_rest(), "a speed that is not a number is not rest");
    }
}
