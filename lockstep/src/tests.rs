//! The lockstep protocol's round trips and its refusals of bad bytes.

use core::num::NonZeroU32;
use std::vec::Vec;

use controller_core::controller::{MotorCommand, TickDeltas};
use controller_core::gyro::GyroSample;
use controller_core::kinematics::{Pose, TrackingError};
use controller_core::supervisor::{
    Bridge, CommandRefusal, DisarmReason, Event, Fault, Faults, RunMode, State,
};

use super::*;

fn step(left: i32, right: i32, periods: u32, button_pressed: bool) -> PlantStep {
    PlantStep {
        ticks: TickDeltas { left, right },
        periods: NonZeroU32::new(periods).unwrap(),
        supply_v: 5.987_654,
        button_pressed,
        gyro: None,
    }
}

fn with_gyro(s: PlantStep, yaw_rate_radps: f32, age_periods: u8) -> PlantStep {
    PlantStep {
        gyro: Some(GyroSample {
            yaw_rate_radps,
            age_periods,
        }),
        ..s
    }
}

fn plant_bytes(s: &PlantStep) -> Vec<u8> {
    let mut out = [0u8; PLANT_STEP_MAX_LEN];
    let len = s.encode(&mut out);
    out[..len].to_vec()
}

fn board_step(event: Option<Event>, steering_updated: bool) -> BoardStep {
    BoardStep {
        duty: MotorCommand {
            left: -0.25,
            right: f32::from_bits(0x3f12_3457),
        },
        bridge: Bridge::Brake,
        state: State::Faulted,
        run_mode: RunMode::HoldWheelSpeeds,
        faults: Faults::NONE
            .with(Fault::StallLeft)
            .with(Fault::EmergencyStop)
            .with(Fault::NonFinite),
        battery_low: true,
        event,
        missed_ticks_total: 12,
        overruns_total: u32::MAX,
        pose: Pose::new(-1.0, 2.5, 3.1),
        error: TrackingError {
            x_e_m: 0.01,
            y_e_m: -0.02,
            theta_e_rad: 1e-7,
        },
        steering_updated,
    }
}

fn board_messages(bytes: &[u8]) -> (Vec<FromBoard>, u32) {
    let mut d = BoardDecoder::new();
    let out = bytes.iter().filter_map(|&b| d.push(b)).collect();
    (out, d.errors())
}

#[test]
fn plant_steps_cross_bit_for_bit_in_few_bytes() {
    let steps = [
        step(-7, 3, 1, false),
        step(i32::MIN, i32::MAX, u32::MAX, true),
        step(0, -1, 12, false),
    ];
    let mut d = StepDecoder::new();
    let mut got = Vec::new();
    for s in &steps {
        got.extend(plant_bytes(s).iter().filter_map(|&b| d.push(b)));
    }
    assert_eq!(got, steps.map(ToBoard::Step));
    // A step of a moving robot: tag, one byte per count, the supply.
    assert_eq!(plant_bytes(&steps[0]).len(), 8);
    assert_eq!(plant_bytes(&steps[0])[0], STEP_TAG);
    assert_eq!(plant_bytes(&steps[1])[0], STEP_PRESSED_TAG);
    // The longest step without a gyro reading: five bytes short of the longest with one.
    assert_eq!(plant_bytes(&steps[1]).len(), PLANT_STEP_MAX_LEN - 5);
    assert_eq!(d.push(FINISH), Some(ToBoard::Finish));
    assert_eq!(d.errors(), 0);
}

#[test]
fn a_gyro_reading_crosses_bit_for_bit_and_a_step_without_one_is_unchanged() {
    let steps = [
        with_gyro(step(-7, 3, 1, false), 0.123_456_7, 0),
        with_gyro(step(i32::MIN, i32::MAX, u32::MAX, true), -34.9, u8::MAX),
        with_gyro(step(0, 0, 1, false), f32::from_bits(0x7fc0_1234), 2),
        step(0, -1, 12, false),
        with_gyro(step(1, 1, 1, true), f32::NEG_INFINITY, 1),
    ];
    let mut d = StepDecoder::new();
    let mut got = Vec::new();
    for s in &steps {
        got.extend(plant_bytes(s).iter().filter_map(|&b| d.push(b)));
    }
    assert_eq!(d.errors(), 0);
    assert_eq!(got.len(), steps.len());
    for (got, sent) in got.iter().zip(&steps) {
        let ToBoard::Step(got) = got else {
            panic!("{got:?}")
        };
        // Bits, not values: a NaN reading must reach the board as the plant sent it.
        let bits = |s: &PlantStep| s.gyro.map(|g| (g.yaw_rate_radps.to_bits(), g.age_periods));
        assert_eq!(bits(got), bits(sent));
        assert_eq!(
            (got.ticks, got.periods, got.button_pressed),
            (sent.ticks, sent.periods, sent.button_pressed)
        );
    }
    // The reading costs five bytes; without one the message is what it always was.
    assert_eq!(plant_bytes(&steps[0]).len(), 8 + 5);
    assert_eq!(plant_bytes(&steps[0])[0], STEP_GYRO_TAG);
    assert_eq!(plant_bytes(&steps[1])[0], STEP_GYRO_PRESSED_TAG);
    assert_eq!(plant_bytes(&steps[1]).len(), PLANT_STEP_MAX_LEN);
    assert_eq!(
        plant_bytes(&step(-7, 3, 1, false)),
        [STEP_TAG, 13, 6, 1, 0xDD, 0x9A, 0xBF, 0x40]
    );
}

#[test]
fn the_details_go_along_only_when_needed_and_the_decoder_keeps_them() {
    let mut encoder = BoardEncoder::new();
    let mut out = [0u8; BOARD_STEP_MAX_LEN];
    let mut bytes = Vec::new();
    let mut send = |s: &BoardStep| {
        let len = encoder.encode(s, &mut out);
        bytes.extend_from_slice(&out[..len]);
        len
    };
    let first = board_step(None, false);
    // The first answer carries the details (the overrun count at its longest).
    assert_eq!(send(&first), 44);
    // Nothing changed, no steering, no event: duties and status only.
    let mut quiet = first;
    quiet.duty.left = 0.5;
    assert_eq!(send(&quiet), 10);
    // The steering law ran: details (the new pose) again.
    let mut steering = quiet;
    steering.steering_updated = true;
    steering.pose.x_m = 7.0;
    assert!(send(&steering) > 10);
    // An event.
    let armed = board_step(Some(Event::Armed(RunMode::FollowPath)), false);
    assert!(send(&armed) > 10);
    // The step after the event: compact again, and the event is not repeated.
    let after_event = board_step(None, false);
    assert_eq!(send(&after_event), 10);
    // A counter changed.
    let mut late = board_step(None, false);
    late.missed_ticks_total += 3;
    assert!(send(&late) > 10);
    let (got, errors) = board_messages(&bytes);
    assert_eq!(errors, 0);
    // Every step comes out whole, the quiet one with the last details.
    assert_eq!(
        got,
        [first, quiet, steering, armed, after_event, late].map(FromBoard::Step)
    );
}

#[test]
fn every_event_and_fault_crosses() {
    let events = [
        None,
        Some(Event::Armed(RunMode::FollowPath)),
        Some(Event::Armed(RunMode::HoldWheelSpeeds)),
        Some(Event::Disarmed(DisarmReason::Button)),
        Some(Event::Disarmed(DisarmReason::Link)),
        Some(Event::Disarmed(DisarmReason::Timeout)),
        Some(Event::Disarmed(DisarmReason::LinkLost)),
        Some(Event::Disarmed(DisarmReason::TuneFinished)),
        Some(Event::Armed(RunMode::Tune)),
        Some(Event::Armed(RunMode::MotorTest)),
        Some(Event::Faulted),
        Some(Event::FaultsCleared),
        Some(Event::ModeSelected(RunMode::FollowPath)),
        Some(Event::BatteryLow),
        Some(Event::PersistStarted),
        Some(Event::PersistEnded),
        Some(Event::PoseSet),
        Some(Event::GyroFailed(controller_core::gyro::GyroFailure::Stuck)),
        Some(Event::GyroFailed(
            controller_core::gyro::GyroFailure::Absent,
        )),
        Some(Event::GyroDisagrees),
        Some(Event::ArmRefused(CommandRefusal::WheelsTurning)),
        Some(Event::ArmRefused(CommandRefusal::ButtonHeld)),
        Some(Event::ArmRefused(CommandRefusal::NonFinitePose)),
        Some(Event::ArmRefused(CommandRefusal::MotorTestOutOfBounds)),
        Some(Event::ArmRefused(CommandRefusal::WrongState(
            State::Faulted,
        ))),
        Some(Event::Armed(RunMode::FollowVelocity)),
        Some(Event::ArmRefused(CommandRefusal::NonFiniteVelocity)),
        Some(Event::ArmRefused(CommandRefusal::WrongMode(RunMode::Tune))),
    ];
    let mut encoder = BoardEncoder::new();
    let mut out = [0u8; BOARD_STEP_MAX_LEN];
    let mut bytes = Vec::new();
    for e in events {
        let len = encoder.encode(&board_step(e, true), &mut out);
        bytes.extend_from_slice(&out[..len]);
    }
    let (got, errors) = board_messages(&bytes);
    assert_eq!(errors, 0);
    let expected: Vec<_> = events
        .iter()
        .map(|&e| FromBoard::Step(board_step(e, true)))
        .collect();
    assert_eq!(got, expected);
    // Each fault alone crosses as itself.
    bytes.clear();
    let steps: Vec<_> = Fault::ALL
        .iter()
        .map(|&f| BoardStep {
            faults: Faults::NONE.with(f),
            ..board_step(None, true)
        })
        .collect();
    for s in &steps {
        let len = encoder.encode(s, &mut out);
        bytes.extend_from_slice(&out[..len]);
    }
    let (got, errors) = board_messages(&bytes);
    assert_eq!(errors, 0);
    let expected: Vec<_> = steps.into_iter().map(FromBoard::Step).collect();
    assert_eq!(got, expected);
}

#[test]
fn a_report_answers_finish() {
    let task = |k: u32| TaskFigures {
        runs: 30_001 + k,
        max_instructions: 11_234 * k,
        total_instructions: 4_000_000_000 - k,
    };
    let r = BoardReport {
        control: task(1),
        control_armed: task(2),
        control_arming: task(3),
        steering: task(4),
        link: task(5),
        link_uart: task(6),
        stack_high_water_bytes: 2048,
        start_stack_bytes: 9000,
    };
    let (got, errors) = board_messages(&r.encode());
    assert_eq!((got, errors), (std::vec![FromBoard::Report(r)], 0));
    assert_eq!(task(0).mean_instructions(), 4e9 / 30_001.0);
    assert_eq!(TaskFigures::default().mean_instructions(), 0.0);
}

#[test]
fn stray_bytes_and_impossible_steps_are_counted_not_acted_on() {
    let mut d = StepDecoder::new();
    assert_eq!(d.push(0x00), None);
    assert_eq!(d.push(b'x'), None);
    assert_eq!(d.errors(), 2);
    // Zero periods: tag, two one-byte counts, a zero, the supply.
    let mut zero = plant_bytes(&step(1, 1, 1, false));
    zero[3] = 0;
    assert!(zero.iter().all(|&b| d.push(b).is_none()));
    assert_eq!(d.errors(), 3);
    // It resynchronises on the next tag.
    let good = step(5, 5, 1, false);
    assert_eq!(
        plant_bytes(&good).iter().filter_map(|&b| d.push(b)).last(),
        Some(ToBoard::Step(good))
    );
    // An out-of-range bridge code on the board's side.
    let mut out = [0u8; BOARD_STEP_MAX_LEN];
    let len = BoardEncoder::new().encode(&board_step(None, false), &mut out);
    out[9] |= 0b11;
    let (got, errors) = board_messages(&out[..len]);
    assert!(got.is_empty());
    // The message and the bytes after it (read as tags) are dropped.
    assert!(errors >= 1);
}
