//! Step 6: the gyro's axis sign and scale, by hand. The robot stands still on the floor
//! while it learns the gyro's bias, then the user turns it one full turn on the spot, back
//! to a mark; the station integrates the gyro's yaw rate over the turn from telemetry and
//! divides the known turn by it: the gyro's `axis_inverted` and `scale`. A robot without
//! a gyro skips the step.
//!
//! The turn's size is the mark's (a hand aligns a mark to a degree or two: 0.3–0.6 % of a
//! turn); odometry checks only that the robot turned about one turn counter-clockwise, as
//! asked, since a hand's turn slips and the track width may not be calibrated yet. A
//! clockwise turn by odometry is refused rather than taken: it is the user's turn the
//! wrong way or encoders whose wiring is not corrected yet, and the axis sign learned
//! from either would be wrong. The rate is integrated between frames (the trapezoid rule
//! on the instantaneous rates of the 50 frames a second the bring-up asks for), which
//! holds to the turn's precision for a turn of a second or more, with the bias the robot
//! had when the turn began: a slow end of the turn that the robot counts as still may
//! move its bias estimate, and must not move the measurement.

use std::f64::consts::TAU;
use std::time::{Duration, Instant};

use controller_core::gyro::{GyroConfig, GyroHealth};
use link::TelemetryFrame;

use super::signals::{catch_up, moved, next_frame, wait_still, Heard};
use super::{BringupError, Finding, Session};
use crate::ops;
use crate::transport::Transport;

/// How long the robot stands still before the turn, for the gyro's bias, s.
pub const BIAS_S: f64 = 2.0;
/// How long the encoders stand still after which the turn is over, s: long enough for a
/// hand to change its grip.
pub const TURN_OVER_S: f64 = 2.0;
/// A "turn" that both the gyro and odometry saw as less than this, rad, is a nudge (a
/// hand taking hold of the robot), not the turn asked for: the watch waits on for the
/// turn. Either sensor may be the one at fault, so one seeing a turn is enough.
const NUDGE_RAD: f64 = std::f64::consts::FRAC_PI_4;
/// How long the station waits for the turn to start and end, host time.
const TURN_LIMIT: Duration = Duration::from_secs(60);
/// Odometry's turn must be one turn within this fraction (a hand's turn slips, and the
/// track width may not be calibrated yet).
const ODOMETRY_TOLERANCE: f64 = 0.25;
/// The scale the step finds (robot turn per sensor turn) must be within this factor of
/// 1, either way: a sensor's own scale error is ±0.5 % and a tilted mounting's
/// 1/cos(tilt) (1.2 at 33°); further off is a wrong full-scale setting, another axis or
/// a loose mounting. Checked on the scale found, not on the correction to the configured
/// one, so that a robot configured with a wrong scale is put right.
const SCALE_LIMIT: f64 = 1.2;

/// A turn by hand as the robot saw it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeasuredTurn {
    /// The gyro's yaw rate integrated over the turn, robot frame as configured (axis
    /// sign, scale and bias applied), counter-clockwise positive, rad.
    pub gyro_rad: f64,
    /// Odometry's heading change over the turn, unwrapped, rad.
    pub odometry_rad: f64,
}

/// Integrates a turn frame by frame, with the bias of its first frame.
#[derive(Clone, Copy, Debug)]
struct TurnWatch {
    last: TelemetryFrame,
    bias_radps: f32,
    period_s: f64,
    turn: MeasuredTurn,
}

impl TurnWatch {
    fn new(first: TelemetryFrame, period_s: f64) -> Self {
        Self {
            last: first,
            bias_radps: first.gyro_bias_radps,
            period_s,
            turn: MeasuredTurn::default(),
        }
    }

    /// `frame`'s gyro rate with the turn's first bias instead of the frame's own, rad/s.
    fn rate_radps(&self, frame: &TelemetryFrame) -> f64 {
        f64::from(frame.gyro_yaw_rate_radps + frame.gyro_bias_radps - self.bias_radps)
    }

    /// Adds the stretch from the last frame to `frame`.
    fn add(&mut self, frame: TelemetryFrame) {
        let dt_s = f64::from(frame.step.wrapping_sub(self.last.step)) * self.period_s;
        let mean_rate = 0.5 * (self.rate_radps(&self.last) + self.rate_radps(&frame));
        self.turn.gyro_rad += mean_rate * dt_s;
        let turned = f64::from(frame.odometry_heading_rad - self.last.odometry_heading_rad);
        // Frames come every 20 ms: a turn by hand is far below half a turn between two.
        self.turn.odometry_rad += robot_files::truth::wrap_angle(turned);
        self.last = frame;
    }
}

/// The gyro configuration `config` corrected by `turn`, one full turn counter-clockwise
/// by the mark.
pub fn learn(config: &GyroConfig, turn: &MeasuredTurn) -> Result<GyroConfig, BringupError> {
    let odometry = turn.odometry_rad;
    if odometry < 0.0 {
        return Err(BringupError::Found(format!(
            "odometry says the robot turned {:.0}°, clockwise: turn it counter-clockwise \
             seen from above, or, if you did, correct the encoders' wiring first (`station \
             bringup encoders`)",
            odometry.to_degrees()
        )));
    }
    if (odometry - TAU).abs() > ODOMETRY_TOLERANCE * TAU {
        return Err(BringupError::Found(format!(
            "odometry says the robot turned {:.0}°, not one turn: turn it one full turn on \
             the spot, back to its mark, with both wheels on the floor; if you did and \
             odometry saw next to nothing, one encoder counts backwards: correct the \
             encoders' wiring first (`station bringup encoders`)",
            odometry.to_degrees()
        )));
    }
    let factor = TAU / turn.gyro_rad;
    let scale = f64::from(config.scale) * factor.abs();
    let seen = format!(
        "the gyro saw {:.0}° of a 360° turn",
        turn.gyro_rad.to_degrees()
    );
    if !scale.is_finite() || scale > SCALE_LIMIT {
        return Err(BringupError::Found(format!(
            "{seen}: its z axis is not vertical (tilted by more than 33°, or another \
             axis), or it is not read"
        )));
    }
    if scale < 1.0 / SCALE_LIMIT {
        return Err(BringupError::Found(format!(
            "{seen}: its full-scale setting is not the configured {:.0}°/s",
            f64::from(config.full_scale_radps).to_degrees()
        )));
    }
    Ok(GyroConfig {
        axis_inverted: config.axis_inverted != (factor < 0.0),
        scale: scale as f32,
        ..*config
    })
}

/// The gyro's state in the newest frame, once it has spoken: `None` for a robot without
/// a gyro.
fn gyro_state<T: Transport>(s: &mut Session<'_, T>) -> Result<Option<GyroHealth>, BringupError> {
    let mut heard = Heard::default();
    let frame = catch_up(s.client, &mut heard)?;
    Ok(match frame.gyro_health {
        GyroHealth::None => None,
        health => Some(health),
    })
}

/// Prints `instruction` and watches the turn it asks for: from the last frame before the
/// encoders move (beyond [`JITTER_COUNTS`](super::signals::JITTER_COUNTS)) to the first
/// after they have stood still for [`TURN_OVER_S`], a nudge ([`NUDGE_RAD`]) left out. The watch starts before the instruction is printed, so that no turn can begin
/// unseen.
fn watch_turn<T: Transport>(
    s: &mut Session<'_, T>,
    instruction: &str,
    period_s: f64,
) -> Result<MeasuredTurn, BringupError> {
    let start = Instant::now();
    let mut heard = Heard::default();
    let mut frame = catch_up(s.client, &mut heard)?;
    writeln!(s.out, "  {instruction}")?;
    s.out.flush()?;
    let turn_over_steps = (TURN_OVER_S / period_s).round() as u32;
    let mut watch = TurnWatch::new(frame, period_s);
    let (mut moving, mut since, mut counts) = (false, frame.step, frame.raw_counts);
    let mut nudged = false;
    let mut last_counts = frame.raw_counts;
    while start.elapsed() < TURN_LIMIT {
        frame = next_frame(s.client, &mut heard)?;
        if let GyroHealth::Failed(why) = frame.gyro_health {
            return Err(failed(why));
        }
        let turning = moved(counts, frame.raw_counts);
        if !moving && !turning && frame.raw_counts == last_counts {
            // Still since the last frame: the turn, if any, starts after this one.
            watch = TurnWatch::new(frame, period_s);
        } else {
            watch.add(frame);
        }
        last_counts = frame.raw_counts;
        if turning {
            (moving, since, counts) = (true, frame.step, frame.raw_counts);
        } else if moving && frame.step.wrapping_sub(since) >= turn_over_steps {
            let t = watch.turn;
            if t.gyro_rad.abs() >= NUDGE_RAD || t.odometry_rad.abs() >= NUDGE_RAD {
                return Ok(t);
            }
            // A nudge: wait on for the turn, from here.
            (moving, nudged) = (false, true);
            watch = TurnWatch::new(frame, period_s);
        }
    }
    Err(BringupError::Silent(if moving {
        "the robot never stood still again after its turn".into()
    } else if nudged {
        "the robot was only nudged (under 45° by the gyro and by odometry): turn it one \
         full turn"
            .into()
    } else {
        "the robot was not turned: its encoders did not count (turn it with its wheels on \
         the floor)"
            .into()
    }))
}

fn failed(why: controller_core::gyro::GyroFailure) -> BringupError {
    BringupError::Found(format!(
        "the gyro has failed ({why:?}): check the IMU's wiring and supply; it is tried \
         again when faults are cleared or at restart"
    ))
}

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let current = ops::get_params(s.client)?;
    match gyro_state(s)? {
        None => {
            return Ok(Finding::only(
                "no gyro reads: nothing to calibrate (the robot steers by its encoders)",
            ))
        }
        Some(GyroHealth::Failed(why)) => return Err(failed(why)),
        Some(_) => {}
    }
    s.answers.until_done(
        s.out,
        "put the robot on the floor with a mark along one side (tape, or a line on the \
         floor) and let go of it",
    )?;
    writeln!(s.out, "  hold still: the robot learns its gyro's bias")?;
    let mut heard = Heard::default();
    let bias_steps = (BIAS_S * f64::from(current.robot.control_rate_hz)).round() as u32;
    let still = wait_still(s.client, bias_steps, &mut heard)?;
    writeln!(
        s.out,
        "  the gyro's bias: {:+.3}°/s",
        f64::from(still.gyro_bias_radps).to_degrees()
    )?;
    let period_s = 1.0 / f64::from(current.robot.control_rate_hz);
    let turn = watch_turn(
        s,
        &format!(
            "now turn the robot by hand one full turn on the spot, counter-clockwise seen \
             from above, wheels on the floor, back to its mark, and let go (the station \
             watches until it has stood still for {TURN_OVER_S:.0} s, so change your grip \
             quicker than that)"
        ),
        period_s,
    )?;
    writeln!(
        s.out,
        "  the gyro turned {:.1}°, odometry {:.1}°, by the mark 360°",
        turn.gyro_rad.to_degrees(),
        turn.odometry_rad.to_degrees(),
    )?;
    let gyro = learn(&current.robot.gyro, &turn)?;
    let summary = format!(
        "gyro axis {}, scale {:.4} (was {:.4})",
        if gyro.axis_inverted {
            "down (inverted)"
        } else {
            "up"
        },
        gyro.scale,
        current.robot.gyro.scale
    );
    let mut learned = current;
    learned.robot.gyro = gyro;
    Ok(Finding {
        summary,
        learned: Some(learned),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GYRO: GyroConfig = GyroConfig::ICM42688P;

    fn turn(gyro_deg: f64, odometry_deg: f64) -> MeasuredTurn {
        MeasuredTurn {
            gyro_rad: gyro_deg.to_radians(),
            odometry_rad: odometry_deg.to_radians(),
        }
    }

    #[test]
    fn a_gyro_reading_3_percent_high_is_scaled_down() {
        let learned = learn(&GYRO, &turn(370.8, 352.0)).expect("one turn");
        assert!(!learned.axis_inverted);
        assert!(
            (learned.scale - 1.0 / 1.03).abs() < 1e-6,
            "{}",
            learned.scale
        );
        assert_eq!(
            GyroConfig {
                scale: GYRO.scale,
                ..learned
            },
            GYRO,
            "nothing else changes"
        );
    }

    #[test]
    fn an_upside_down_gyro_is_inverted_and_a_correction_composes() {
        let learned = learn(&GYRO, &turn(-360.0, 365.0)).expect("one turn");
        assert!(learned.axis_inverted && learned.scale == 1.0);
        // Already inverted and scaled 0.5 (wrongly), the gyro now sees half the turn the
        // wrong way: the scale found is 1, and it is taken.
        let configured = GyroConfig {
            axis_inverted: true,
            scale: 0.5,
            ..GYRO
        };
        let learned = learn(&configured, &turn(-180.0, 340.0)).expect("one turn");
        assert!(!learned.axis_inverted);
        assert!((learned.scale - 1.0).abs() < 1e-6, "{}", learned.scale);
    }

    #[test]
    fn a_turn_that_is_not_one_turn_or_a_gyro_that_did_not_see_it_is_named() {
        for (gyro, odometry, words) in [
            (180.0, 180.0, "not one turn"),
            (360.0, 460.0, "not one turn"),
            (-360.0, -360.0, "clockwise"),
            (10.0, 360.0, "not vertical"),
            // Mounted 45° off vertical: no scale error a calibration should take.
            (254.6, 360.0, "not vertical"),
            (900.0, 360.0, "full-scale"),
            (720.0, 360.0, "full-scale"),
            (30.0, 5.0, "one encoder counts backwards"),
            (0.0, 360.0, "not vertical"),
        ] {
            match learn(&GYRO, &turn(gyro, odometry)) {
                Err(BringupError::Found(text)) => assert!(text.contains(words), "{text}"),
                other => panic!("{gyro}° {odometry}°: {other:?}"),
            }
        }
    }

    #[test]
    fn the_watch_keeps_the_bias_the_turn_began_with() {
        // The robot's bias estimate moves during the turn (a slow end the robot counts as
        // still): the rate it reports moves the other way, and the turn must not.
        // The sensor's offset is 0.01 rad/s, which the first estimate has right.
        let frame = |step: u32, rate: f32, bias: f32| TelemetryFrame {
            gyro_yaw_rate_radps: rate + 0.01 - bias,
            gyro_bias_radps: bias,
            ..crate::test_frames::still(step)
        };
        let mut watch = TurnWatch::new(frame(0, 0.0, 0.01), 0.001);
        watch.add(frame(20, 1.0, 0.01));
        watch.add(frame(40, 1.0, 0.05));
        watch.add(frame(60, 0.0, 0.09));
        assert!(
            (watch.turn.gyro_rad - 0.04).abs() < 1e-7,
            "{:?}",
            watch.turn
        );
    }

    #[test]
    fn the_watch_integrates_the_rate_and_unwraps_odometry() {
        let frame = |step: u32, rate: f32, heading: f32| TelemetryFrame {
            gyro_yaw_rate_radps: rate,
            odometry_heading_rad: heading,
            ..crate::test_frames::still(step)
        };
        let mut watch = TurnWatch::new(frame(100, 0.0, 3.0), 0.001);
        // 1 rad/s for 20 ms on average; odometry crosses ±π (3.0 → −3.0 is +0.283 rad).
        watch.add(frame(120, 2.0, -3.0));
        watch.add(frame(140, 0.0, -2.9));
        assert!(
            (watch.turn.gyro_rad - 0.04).abs() < 1e-9,
            "{:?}",
            watch.turn
        );
        let expected = (TAU - 6.0) + 0.1;
        assert!(
            (watch.turn.odometry_rad - expected).abs() < 1e-6,
            "{:?}",
            watch.turn
        );
    }
}
