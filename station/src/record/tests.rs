//! Telemetry counts, the final window and the final state of a recorded run.

use controller_core::supervisor::{DisarmReason, Event, State};

use super::recorder::final_state;
use super::*;

#[test]
fn gaps_in_the_step_numbers_count_the_missing_frames() {
    // A 100-step run, a frame every 10 steps from step 3: 10 due (3, 13, …, 93).
    let mut all = GapCounter::default();
    for k in (3..100).step_by(10) {
        all.push(k, 10);
    }
    assert_eq!(all.count(100, 10), (10, 0));
    // Without 3 (the first), 43 and 53 (a gap of two), 93 (the last), and one a step
    // late (a late control step).
    let mut some = GapCounter::default();
    for k in [13, 23, 34, 63, 73, 83] {
        some.push(k, 10);
    }
    assert_eq!(some.count(100, 10), (6, 4));
    // Nothing received: every frame is missing.
    assert_eq!(GapCounter::default().count(100, 10), (0, 10));
}

#[test]
fn missing_telemetry_past_five_percent_is_warned_about() {
    let count = |missing| TelemetryCount {
        rate_hz: 100,
        period_steps: 10,
        expected_frames: 1000,
        received_frames: 1000 - missing,
        missing_frames: missing,
        dropped_on_robot: Some(20),
    };
    assert_eq!(count(50).warning(), None);
    assert!(count(51).warning().is_some());
    assert_eq!(
        count(450).text(),
        "telemetry: 550 of 1000 frames at 100 Hz (450 missing, 45.0 %; 20 dropped on the \
robot for want of link room, 430 lost on the line)"
    );
}

#[test]
fn the_final_window_is_the_last_ten_whole_seconds_or_the_whole_run() {
    assert_eq!(final_window(30.0), (20.0, 30.0));
    assert_eq!(final_window(5.4), (0.0, 5.4));
    assert_eq!(final_window(10.0), (0.0, 10.0));
    // The samples of 6 s to 15.5 s: the whole seconds 6 to 15.
    assert_eq!(final_window(15.5), (6.0, 15.5));
    assert_eq!(final_window_text(30.0), "over 20.0–30.0 s");
    assert_eq!(final_window_text(5.4), "over the whole run (0.0–5.4 s)");
}

#[test]
fn the_final_state_is_the_one_the_ending_event_led_to() {
    assert_eq!(
        final_state(State::Armed, Some(Event::Disarmed(DisarmReason::Timeout))),
        State::Disarmed
    );
    assert_eq!(
        final_state(State::Armed, Some(Event::Faulted)),
        State::Faulted
    );
    assert_eq!(final_state(State::Armed, None), State::Armed);
    assert_eq!(final_state(State::Disarmed, None), State::Disarmed);
}
