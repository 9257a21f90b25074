//! Step 5: the motors, the wheels lifted. A short low-voltage pulse per motor and
//! direction ([`Request::MotorTest`]); the board's raw counts, read through the encoders'
//! corrections (step 4), say which wheel turned and which way: each motor's output and
//! sign, whether the motors are swapped, and any motor that does not respond.

use controller_core::controller::TickDeltas;
use controller_core::supervisor::{Event, Wheel};
use controller_core::wiring::WiringConfig;
use link::{NotPermitted, Refusal, Request, MOTOR_TEST_CONFIRMATION};

use super::encoders::{configured_counts_per_turn, STILL_STEPS};
use super::signals::{counted, wait_event, wait_still, Heard};
use super::{BringupError, Finding, Session};
use crate::client::StationError;
use crate::ops;
use crate::transport::Transport;

/// The pulse's voltage, V (below the stall check's, so a wheel that does not follow is
/// not a fault, and within the robot's 3 V bound).
pub const PULSE_V: f32 = 2.5;
/// The pulse's length, ms.
pub const PULSE_MS: u16 = 300;
/// Control steps the station waits for a pulse to end.
const PULSE_WAIT_STEPS: u32 = 3000;
/// A wheel that turned less than this fraction of a turn did not respond.
const MOVED_FRACTION: f64 = 0.02;

/// What one pulse did: the wheel that turned and whether it turned forward.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    /// The wheel that turned.
    pub wheel: Wheel,
    /// It turned forward.
    pub forward: bool,
}

fn name(wheel: Wheel) -> &'static str {
    match wheel {
        Wheel::Left => "left",
        Wheel::Right => "right",
    }
}

fn other(wheel: Wheel) -> Wheel {
    match wheel {
        Wheel::Left => Wheel::Right,
        Wheel::Right => Wheel::Left,
    }
}

/// The wheel a pulse turned, from the board's counts `delta` read through `encoders`
/// (the robot's encoder corrections), for a robot of `counts_per_turn`; `None` when
/// neither wheel turned.
pub fn response(
    delta: [i64; 2],
    encoders: &WiringConfig,
    counts_per_turn: f64,
) -> Option<Response> {
    let clamp = |v: i64| v.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
    let wheels = encoders.ticks_from_board(TickDeltas {
        left: clamp(delta[0]),
        right: clamp(delta[1]),
    });
    let (wheel, ticks) = if wheels.left.unsigned_abs() >= wheels.right.unsigned_abs() {
        (Wheel::Left, wheels.left)
    } else {
        (Wheel::Right, wheels.right)
    };
    (f64::from(ticks.unsigned_abs()) >= MOVED_FRACTION * counts_per_turn).then_some(Response {
        wheel,
        forward: ticks > 0,
    })
}

/// The motor corrections of `wiring` (the robot's present ones) made right by what a
/// forward pulse of each wheel's motor did: `left` and `right` are the responses to
/// pulsing the left and the right wheel through `wiring`.
pub fn learn(
    wiring: &WiringConfig,
    left: Response,
    right: Response,
) -> Result<WiringConfig, BringupError> {
    // Through `wiring`, pulsing wheel W drives this board output with this sign.
    let output_of = |w: Wheel| if wiring.motors_swapped { other(w) } else { w };
    let sign_of = |w: Wheel| match w {
        Wheel::Left => !wiring.left_motor_inverted,
        Wheel::Right => !wiring.right_motor_inverted,
    };
    if left.wheel == right.wheel {
        return Err(BringupError::Found(format!(
            "both motors turn the {} wheel: check the bridge's outputs",
            name(left.wheel)
        )));
    }
    let mut learned = *wiring;
    for (pulsed, seen) in [(Wheel::Left, left), (Wheel::Right, right)] {
        // Board output `output_of(pulsed)`, driven positive when `sign_of(pulsed)`, turned
        // wheel `seen.wheel` forward when `seen.forward`.
        let output = output_of(pulsed);
        let positive_turns_forward = sign_of(pulsed) == seen.forward;
        if output == Wheel::Left {
            learned.motors_swapped = seen.wheel == Wheel::Right;
        }
        match seen.wheel {
            Wheel::Left => learned.left_motor_inverted = !positive_turns_forward,
            Wheel::Right => learned.right_motor_inverted = !positive_turns_forward,
        }
    }
    Ok(learned)
}

/// One pulse of `wheel`'s motor at `volts`: waits for the wheels to stand still, pulses,
/// waits for the end and the wheels to stop again; returns the board's counts.
fn pulse<T: Transport>(
    s: &mut Session<'_, T>,
    wheel: Wheel,
    volts: f32,
) -> Result<[i64; 2], BringupError> {
    let mut heard = Heard::default();
    let before = wait_still(s.client, STILL_STEPS, &mut heard)?.raw_counts;
    heard.events.clear();
    let request = Request::MotorTest {
        wheel,
        volts,
        duration_ms: PULSE_MS,
        confirm: MOTOR_TEST_CONFIRMATION,
    };
    let mut tries = 0;
    loop {
        match s.client.command(request.clone()) {
            Ok(()) => break,
            // The supervisor's own rest check is stricter than the counts holding still.
            Err(StationError::Refused { refusal, .. })
                if *refusal == Refusal::NotPermitted(NotPermitted::WheelsTurning) && tries < 10 =>
            {
                tries += 1;
                wait_still(s.client, STILL_STEPS, &mut heard)?;
            }
            Err(e) => return Err(e.into()),
        }
    }
    let ended = wait_event(s.client, PULSE_WAIT_STEPS, &mut heard, |e| {
        matches!(e, Event::Disarmed(_) | Event::Faulted)
    })?;
    if ended == Some(Event::Faulted) {
        writeln!(s.out, "  the pulse ended in a fault; clearing it")?;
        s.client.command(Request::ClearFaults)?;
    } else if ended.is_none() {
        s.client.command(Request::Disarm)?;
        return Err(BringupError::Silent(
            "the motor pulse did not end: the robot was disarmed".into(),
        ));
    }
    let after = wait_still(s.client, STILL_STEPS, &mut heard)?.raw_counts;
    Ok(counted(before, after))
}

/// Pulses `wheel`'s motor forward and back; returns what the forward pulse did.
fn both_ways<T: Transport>(
    s: &mut Session<'_, T>,
    wheel: Wheel,
    encoders: &WiringConfig,
    counts_per_turn: f64,
) -> Result<Response, BringupError> {
    let mut seen = [None, None];
    for (i, volts) in [PULSE_V, -PULSE_V].into_iter().enumerate() {
        let delta = pulse(s, wheel, volts)?;
        writeln!(
            s.out,
            "  {} motor at {volts:+} V: the board's inputs counted {} (left) and {} (right)",
            name(wheel),
            delta[0],
            delta[1]
        )?;
        seen[i] = response(delta, encoders, counts_per_turn);
    }
    match seen {
        [Some(forward), Some(back)]
            if forward.wheel == back.wheel && forward.forward != back.forward =>
        {
            Ok(forward)
        }
        [None, None] => Err(BringupError::Found(format!(
            "the {} motor does not respond: no wheel turned (check the motor, its bridge \
             channel and the bridge's supply)",
            name(wheel)
        ))),
        _ => Err(BringupError::Found(format!(
            "the {} motor's pulses forward and back did not turn one wheel both ways \
             ({seen:?}): check that the wheels turn freely",
            name(wheel)
        ))),
    }
}

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let current = ops::get_params(s.client)?;
    s.answers.until_done(
        s.out,
        "lift the robot so that both wheels are off the ground and free to turn",
    )?;
    let counts_per_turn = configured_counts_per_turn(&current.robot);
    let wiring = current.robot.wiring;
    let left = both_ways(s, Wheel::Left, &wiring, counts_per_turn)?;
    let right = both_ways(s, Wheel::Right, &wiring, counts_per_turn)?;
    let learned_wiring = learn(&wiring, left, right)?;
    let summary = format!(
        "motors {}; left {}, right {}",
        if learned_wiring.motors_swapped {
            "swapped"
        } else {
            "on their outputs"
        },
        if learned_wiring.left_motor_inverted {
            "inverted"
        } else {
            "turns forward"
        },
        if learned_wiring.right_motor_inverted {
            "inverted"
        } else {
            "turns forward"
        },
    );
    let mut learned = current;
    learned.robot.wiring = learned_wiring;
    Ok(Finding {
        summary,
        learned: Some(learned),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const AS_BUILT: WiringConfig = WiringConfig::AS_BUILT;

    fn seen(wheel: Wheel, forward: bool) -> Response {
        Response { wheel, forward }
    }

    #[test]
    fn a_swapped_pair_with_one_inverted_motor_is_found() {
        // Pulsing the left motor turned the right wheel back; the right's, the left
        // wheel forward.
        let learned = learn(
            &AS_BUILT,
            seen(Wheel::Right, false),
            seen(Wheel::Left, true),
        )
        .expect("consistent");
        assert!(learned.motors_swapped);
        assert!(learned.right_motor_inverted && !learned.left_motor_inverted);
    }

    #[test]
    fn a_correct_robot_stays_correct_and_a_corrected_one_too() {
        let right = learn(&AS_BUILT, seen(Wheel::Left, true), seen(Wheel::Right, true));
        assert_eq!(right.ok(), Some(AS_BUILT));
        // Already corrected for a swapped pair with the left inverted: through those
        // corrections every wheel now turns as asked, and they stay.
        let corrected = WiringConfig {
            motors_swapped: true,
            left_motor_inverted: true,
            ..AS_BUILT
        };
        let again = learn(
            &corrected,
            seen(Wheel::Left, true),
            seen(Wheel::Right, true),
        );
        assert_eq!(again.ok(), Some(corrected));
    }

    #[test]
    fn the_response_reads_the_counts_through_the_encoders_corrections() {
        let encoders = WiringConfig {
            encoders_swapped: true,
            left_encoder_inverted: true,
            ..AS_BUILT
        };
        // The board's right input counted down: the left wheel turned forward.
        assert_eq!(
            response([0, -400], &encoders, 1440.0),
            Some(seen(Wheel::Left, true))
        );
        assert_eq!(
            response([3, -5], &encoders, 1440.0),
            None,
            "did not respond"
        );
        let both = learn(&AS_BUILT, seen(Wheel::Left, true), seen(Wheel::Left, false));
        assert!(matches!(both, Err(BringupError::Found(_))));
    }
}
