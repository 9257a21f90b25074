//! Step 4: the encoders, by hand. The user turns each wheel forward one turn; the board's
//! raw counts (before any correction) say which input the wheel's encoder is on, which
//! way it counts and how many counts a turn is: the encoders' swap and inversion flags,
//! and the encoder's lines against the configured ones.

use controller_core::params::RobotConfig;
use controller_core::supervisor::Wheel;

use super::signals::{counted, wait_still, Heard};
use super::{BringupError, Finding, Session};
use crate::ops;
use crate::transport::Transport;

/// Control steps the counts must hold still before and after a turn.
pub const STILL_STEPS: u32 = 200;
/// Counts per turn within this fraction of the configured ones are the configured ones
/// (a turn by hand is not exact).
const CPR_TOLERANCE: f64 = 0.1;

/// What one wheel's turn showed on the board's inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelTurn {
    /// The board's input that counted.
    pub input: Wheel,
    /// It counted down for a forward turn.
    pub inverted: bool,
    /// Counts in the turn, unsigned.
    pub counts: i64,
}

/// The configured counts per wheel turn of `robot` (quadrature: 4 per line).
pub fn configured_counts_per_turn(robot: &RobotConfig) -> f64 {
    f64::from(robot.encoder_lines_per_motor_rev) * 4.0 * f64::from(robot.gear_ratio)
}

fn name(wheel: Wheel) -> &'static str {
    match wheel {
        Wheel::Left => "left",
        Wheel::Right => "right",
    }
}

/// What a forward turn of `wheel` that changed the board's counts by `delta` shows, for
/// a robot configured with `expected` counts per turn.
pub fn read_turn(wheel: Wheel, delta: [i64; 2], expected: f64) -> Result<WheelTurn, BringupError> {
    let (input, counts, other) = if delta[0].abs() >= delta[1].abs() {
        (Wheel::Left, delta[0], delta[1])
    } else {
        (Wheel::Right, delta[1], delta[0])
    };
    if (counts.abs() as f64) < 0.05 * expected {
        return Err(BringupError::Found(format!(
            "turning the {} wheel counted {} and {} on the board's inputs: its encoder does \
             not count (check its supply, its two channels and its connector)",
            name(wheel),
            delta[0],
            delta[1]
        )));
    }
    if other.abs() * 4 > counts.abs() {
        return Err(BringupError::Found(format!(
            "turning the {} wheel counted on both of the board's inputs ({} and {}): turn \
             one wheel only, or check for encoder channels wired across the two inputs",
            name(wheel),
            delta[0],
            delta[1]
        )));
    }
    Ok(WheelTurn {
        input,
        inverted: counts < 0,
        counts: counts.abs(),
    })
}

/// The robot configuration `robot` corrected by the turns of its left and right wheels.
pub fn learn(
    robot: &RobotConfig,
    left: WheelTurn,
    right: WheelTurn,
) -> Result<RobotConfig, BringupError> {
    if left.input == right.input {
        return Err(BringupError::Found(format!(
            "both wheels count on the board's {} input: one encoder is wired to both \
             inputs, or the other encoder does not count",
            name(left.input)
        )));
    }
    let mut learned = *robot;
    learned.wiring.encoders_swapped = left.input == Wheel::Right;
    learned.wiring.left_encoder_inverted = left.inverted;
    learned.wiring.right_encoder_inverted = right.inverted;
    let measured = (left.counts + right.counts) as f64 / 2.0;
    let ratio = measured / configured_counts_per_turn(robot);
    if (ratio - 1.0).abs() > CPR_TOLERANCE {
        let lines = (f64::from(robot.encoder_lines_per_motor_rev) * ratio).round();
        if lines < 1.0 || lines > f64::from(u32::MAX) {
            return Err(BringupError::Found(format!(
                "{measured} counts per turn match no encoder at gear ratio {}",
                robot.gear_ratio
            )));
        }
        learned.encoder_lines_per_motor_rev = lines as u32;
    }
    Ok(learned)
}

/// Waits for the wheels to stand still, asks the user to turn `wheel` forward one turn,
/// and returns what the board counted.
fn turn<T: Transport>(
    s: &mut Session<'_, T>,
    wheel: Wheel,
    expected: f64,
) -> Result<WheelTurn, BringupError> {
    let mut heard = Heard::default();
    let before = wait_still(s.client, STILL_STEPS, &mut heard)?.raw_counts;
    s.answers.until_done(
        s.out,
        &format!(
            "turn the {} wheel forward one turn by hand (mark the tyre; forward is the way \
             the robot drives ahead)",
            name(wheel)
        ),
    )?;
    let after = wait_still(s.client, STILL_STEPS, &mut heard)?.raw_counts;
    let delta = counted(before, after);
    writeln!(
        s.out,
        "  the board's inputs counted {} (left) and {} (right)",
        delta[0], delta[1]
    )?;
    read_turn(wheel, delta, expected)
}

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let current = ops::get_params(s.client)?;
    let expected = configured_counts_per_turn(&current.robot);
    s.answers.until_done(
        s.out,
        "lift the robot so that both wheels turn freely (the motors are off)",
    )?;
    let left = turn(s, Wheel::Left, expected)?;
    let right = turn(s, Wheel::Right, expected)?;
    let robot = learn(&current.robot, left, right)?;
    let w = &robot.wiring;
    let summary = format!(
        "encoders {}; left {}, right {}; {} counts per turn ({} lines, configured {})",
        if w.encoders_swapped {
            "swapped"
        } else {
            "on their inputs"
        },
        if w.left_encoder_inverted {
            "inverted"
        } else {
            "counts forward"
        },
        if w.right_encoder_inverted {
            "inverted"
        } else {
            "counts forward"
        },
        (left.counts + right.counts) / 2,
        robot.encoder_lines_per_motor_rev,
        current.robot.encoder_lines_per_motor_rev
    );
    let mut learned = current;
    learned.robot = robot;
    Ok(Finding {
        summary,
        learned: Some(learned),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROBOT: RobotConfig = RobotConfig::REFERENCE_ROBOT;

    #[test]
    fn turns_on_swapped_inputs_one_counting_down_are_found() {
        let expected = configured_counts_per_turn(&ROBOT);
        assert_eq!(expected, 1440.0);
        let left = read_turn(Wheel::Left, [2, -1440], expected).expect("counted");
        let right = read_turn(Wheel::Right, [1441, 0], expected).expect("counted");
        assert_eq!(
            left,
            WheelTurn {
                input: Wheel::Right,
                inverted: true,
                counts: 1440
            }
        );
        let robot = learn(&ROBOT, left, right).expect("consistent");
        assert!(robot.wiring.encoders_swapped);
        assert!(robot.wiring.left_encoder_inverted && !robot.wiring.right_encoder_inverted);
        assert_eq!(
            robot.encoder_lines_per_motor_rev, 12,
            "within a hand's turn"
        );
    }

    #[test]
    fn an_encoder_of_twice_the_lines_is_configured() {
        let left = read_turn(Wheel::Left, [2880, 0], 1440.0).expect("counted");
        let right = read_turn(Wheel::Right, [0, 2878], 1440.0).expect("counted");
        let robot = learn(&ROBOT, left, right).expect("consistent");
        assert_eq!(robot.encoder_lines_per_motor_rev, 24);
        assert_eq!(robot.wiring, ROBOT.wiring, "wired as labelled");
    }

    #[test]
    fn a_silent_encoder_and_a_shared_input_are_named() {
        let silent = read_turn(Wheel::Right, [0, 3], 1440.0);
        assert!(matches!(silent, Err(BringupError::Found(t)) if t.contains("right wheel")));
        let both = read_turn(Wheel::Left, [1440, 1200], 1440.0);
        assert!(matches!(both, Err(BringupError::Found(t)) if t.contains("both")));
        let turn = WheelTurn {
            input: Wheel::Left,
            inverted: false,
            counts: 1440,
        };
        assert!(matches!(
            learn(&ROBOT, turn, turn),
            Err(BringupError::Found(_))
        ));
    }
}
