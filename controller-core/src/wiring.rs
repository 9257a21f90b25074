//! How the board's motor outputs and encoder inputs are wired to the wheels, and the
//! scale of its supply reading: the corrections a bring-up learns, applied where the
//! encoder deltas come in from the board and the duties go out to it.
//!
//! The board's channels are named after the wheel they are meant for ("left" is the
//! encoder input and motor output the board labels left). A miswired robot is corrected
//! by these flags, not by swapping wires:
//!
//! ```text
//!  board encoder inputs (left, right) ──► swap if encoders_swapped ──► negate each
//!      wheel whose encoder is inverted ──► ticks per wheel, forward positive
//!  duties per wheel (forward positive) ──► negate each wheel whose motor is inverted
//!      ──► swap if motors_swapped ──► board motor outputs (left, right)
//! ```
//!
//! Each flag names what is true of the robot: `left_encoder_inverted` says the left
//! wheel's encoder counts down when that wheel turns forward, `encoders_swapped` that
//! the left wheel's encoder is on the board's right input. [`WiringConfig::AS_BUILT`]
//! changes nothing.

use crate::controller::{MotorCommand, TickDeltas};

/// The robot's wiring corrections (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct WiringConfig {
    /// The left motor turns its wheel backward for a positive duty.
    pub left_motor_inverted: bool,
    /// The right motor turns its wheel backward for a positive duty.
    pub right_motor_inverted: bool,
    /// The left wheel's motor is on the board's right output, and the right's on the left.
    pub motors_swapped: bool,
    /// The left wheel's encoder counts down when the wheel turns forward.
    pub left_encoder_inverted: bool,
    /// The right wheel's encoder counts down when the wheel turns forward.
    pub right_encoder_inverted: bool,
    /// The left wheel's encoder is on the board's right input, and the right's on the left.
    pub encoders_swapped: bool,
    /// The true supply over the board's reading of it (its divider's error),
    /// dimensionless, in [[`MIN_CALIBRATION_SCALE`](crate::params::MIN_CALIBRATION_SCALE),
    /// [`MAX_CALIBRATION_SCALE`](crate::params::MAX_CALIBRATION_SCALE)]: a multimeter
    /// reading of 7.40 V against a board reading of 7.29 V gives 1.015.
    pub supply_scale: f32,
}

impl WiringConfig {
    /// The board wired as labelled and its divider exact: nothing is corrected.
    pub const AS_BUILT: WiringConfig = WiringConfig {
        left_motor_inverted: false,
        right_motor_inverted: false,
        motors_swapped: false,
        left_encoder_inverted: false,
        right_encoder_inverted: false,
        encoders_swapped: false,
        supply_scale: 1.0,
    };

    /// The ticks of each wheel (forward positive) from the board's encoder inputs,
    /// `board.left` and `board.right` being its left and right inputs. Wrapping
    /// negation: a counter delta of `i32::MIN` stays the encoder-jump fault it was.
    pub const fn ticks_from_board(&self, board: TickDeltas) -> TickDeltas {
        let (left, right) = if self.encoders_swapped {
            (board.right, board.left)
        } else {
            (board.left, board.right)
        };
        TickDeltas {
            left: if self.left_encoder_inverted {
                left.wrapping_neg()
            } else {
                left
            },
            right: if self.right_encoder_inverted {
                right.wrapping_neg()
            } else {
                right
            },
        }
    }

    /// The duties of the board's left and right motor outputs for the duties `wheels`
    /// of each wheel (forward positive).
    pub fn duties_to_board(&self, wheels: MotorCommand) -> MotorCommand {
        let left = if self.left_motor_inverted {
            -wheels.left
        } else {
            wheels.left
        };
        let right = if self.right_motor_inverted {
            -wheels.right
        } else {
            wheels.right
        };
        if self.motors_swapped {
            MotorCommand {
                left: right,
                right: left,
            }
        } else {
            MotorCommand { left, right }
        }
    }

    /// The supply, V, from the board's reading `board_v` (V; NaN stays NaN).
    pub fn supply_from_board(&self, board_v: f32) -> f32 {
        board_v * self.supply_scale
    }
}

impl Default for WiringConfig {
    fn default() -> Self {
        Self::AS_BUILT
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::calibration_scale;

    const TICKS: TickDeltas = TickDeltas { left: 3, right: -7 };
    const DUTY: MotorCommand = MotorCommand {
        left: 0.25,
        right: -0.5,
    };

    #[test]
    fn as_built_changes_nothing() {
        let w = WiringConfig::AS_BUILT;
        assert_eq!(w.ticks_from_board(TICKS), TICKS);
        assert_eq!(w.duties_to_board(DUTY), DUTY);
        assert_eq!(w.supply_from_board(7.4), 7.4);
        assert!(calibration_scale(w.supply_scale, "wiring.supply_scale").is_ok());
    }

    #[test]
    fn swapped_encoders_trade_inputs_before_the_wheels_signs() {
        let w = WiringConfig {
            encoders_swapped: true,
            left_encoder_inverted: true,
            ..WiringConfig::AS_BUILT
        };
        // The left wheel's encoder is on the right input (−7) and counts backwards.
        assert_eq!(w.ticks_from_board(TICKS), TickDeltas { left: 7, right: 3 });
        assert_eq!(
            w.ticks_from_board(TickDeltas {
                left: i32::MIN,
                right: 0
            }),
            TickDeltas {
                left: 0,
                right: i32::MIN
            }
        );
    }

    #[test]
    fn an_inverted_left_motor_negates_the_left_duty_alone() {
        let w = WiringConfig {
            left_motor_inverted: true,
            ..WiringConfig::AS_BUILT
        };
        assert_eq!(
            w.duties_to_board(DUTY),
            MotorCommand {
                left: -DUTY.left,
                right: DUTY.right
            }
        );
    }

    #[test]
    fn an_inverted_motor_is_negated_before_the_swap() {
        let w = WiringConfig {
            motors_swapped: true,
            right_motor_inverted: true,
            ..WiringConfig::AS_BUILT
        };
        // The right wheel's duty (−0.5), negated, goes out on the board's left output.
        assert_eq!(
            w.duties_to_board(DUTY),
            MotorCommand {
                left: 0.5,
                right: 0.25
            }
        );
    }

    #[test]
    fn the_supply_scale_multiplies_and_has_a_range() {
        let w = WiringConfig {
            supply_scale: 1.1,
            ..WiringConfig::AS_BUILT
        };
        assert!((w.supply_from_board(10.0) - 11.0).abs() < 1e-5);
        for bad in [0.0, 0.49, 2.01, f32::NAN, f32::INFINITY] {
            assert!(
                calibration_scale(bad, "wiring.supply_scale").is_err(),
                "{bad}"
            );
        }
    }
}
