//! The link service against the host's end of the protocol, on the fake board: framing,
//! requests answered by the link side, configuration changes, hostile bytes, back
//! pressure.

mod support;

use std::cell::Cell;

use controller_core::supervisor::{Event, RunMode, State};
use link::{
    encode_raw, params_hash, ArmMode, FieldProblem, ProtocolId, Refusal, Reply, Request, Uplink,
    PROTOCOL_VERSION,
};
use robot_app::panic_record::{PanicRecord, PanicRecordStore};
use robot_app::{service::TX_CAPACITY, BoardStats, Channels};
use support::{app_config, default_params, Rig, IDENTITY};

const BAUD: u32 = 921_600;

/// Asks each request and checks it is refused naming its field as not finite.
fn refuses_each_as_not_finite<const N: usize>(rig: &mut Rig<'_>, cases: [(Request, &str); N]) {
    for (request, field) in cases {
        assert_eq!(
            rig.ask(request),
            Err(Refusal::InvalidArgument(FieldProblem::new(
                field,
                "must be finite"
            ))),
            "{field}"
        );
    }
}

#[test]
fn requests_in_random_chunks_get_their_replies() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    // Many requests back to back, fed to the robot in random-size chunks.
    let seqs: Vec<u16> = (0..40)
        .map(|i| rig.send(Request::Ping { nonce: 1000 + i }))
        .collect();
    rig.run(50);
    for (i, &seq) in seqs.iter().enumerate() {
        assert_eq!(
            rig.reply(seq),
            Some(Ok(Reply::Pong {
                nonce: 1000 + i as u32
            }))
        );
        assert_eq!(rig.replies_to(seq), 1, "exactly one reply");
    }
}

#[test]
fn info_names_the_robot_and_its_parameters() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let Ok(Reply::Info(info)) = rig.ask(Request::Info) else {
        panic!("no info");
    };
    assert_eq!(info.protocol, ProtocolId::OURS);
    assert_eq!(info.firmware_version.as_str(), IDENTITY.firmware_version);
    assert_eq!(info.git_hash.as_str(), IDENTITY.git_hash);
    assert_eq!(info.chip.as_str(), IDENTITY.chip);
    assert_eq!(info.robot_name.as_str(), IDENTITY.robot_name);
    assert_eq!(info.params_hash, params_hash(&default_params()));
    assert_eq!(info.clock, IDENTITY.clock);
    assert_eq!(info.brown_out_reset, IDENTITY.brown_out_reset);
    assert_eq!(
        rig.ask(Request::GetParams),
        Ok(Reply::Params(default_params()))
    );
}

#[test]
fn info_reports_why_the_chip_last_reset() {
    use controller_core::supervisor::ResetCause;
    for cause in [
        ResetCause::Watchdog,
        ResetCause::BrownOut,
        ResetCause::PowerOn,
    ] {
        let mut channels = Channels::new();
        let mut config = app_config(BAUD, false);
        config.reset = cause;
        let mut rig = Rig::with_config(&mut channels, config);
        let Ok(Reply::Info(info)) = rig.ask(Request::Info) else {
            panic!("no info");
        };
        assert_eq!(info.reset_cause, cause);
    }
}

/// A board whose RAM holds a panic record, as the firmware's does after a panic.
struct RetainedRecord(Cell<Option<PanicRecord>>);

impl BoardStats for RetainedRecord {
    fn max_step_cycles(&self) -> u32 {
        0
    }
    fn stack_high_water_bytes(&self) -> u32 {
        0
    }
}

impl PanicRecordStore for RetainedRecord {
    fn panic_record(&self) -> Option<PanicRecord> {
        self.0.get()
    }
    fn clear_panic_record(&self) {
        self.0.set(None);
    }
}

#[test]
fn the_panic_record_stays_until_the_host_clears_it() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let mut record = PanicRecord::panic("firmware/src/board/f411/motor.rs", 42);
    record.message_mut().push_str("index out of bounds");
    let board = RetainedRecord(Cell::new(Some(record)));
    let ask = |rig: &mut Rig<'_>, request: Request| {
        let seq = rig.send(request);
        let bytes = std::mem::take(&mut rig.to_robot);
        assert_eq!(rig.link.receive(&bytes, &board), bytes.len());
        rig.drain_tx();
        rig.reply(seq).expect("answered at once")
    };
    // Reading twice (a lost reply asked again) gives the record both times.
    for _ in 0..2 {
        assert_eq!(
            ask(&mut rig, Request::GetPanicRecord),
            Ok(Reply::PanicRecord(Some(record.report())))
        );
    }
    assert_eq!(ask(&mut rig, Request::ClearPanicRecord), Ok(Reply::Ack));
    assert_eq!(board.0.get(), None, "cleared where the board keeps it");
    assert_eq!(
        ask(&mut rig, Request::GetPanicRecord),
        Ok(Reply::PanicRecord(None))
    );
    // Clearing again is no error.
    assert_eq!(ask(&mut rig, Request::ClearPanicRecord), Ok(Reply::Ack));
}

#[test]
fn corrupted_bytes_never_panic_and_are_counted() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let mut frame = Vec::new();
    for nonce in 0..20u32 {
        let seq = rig.fresh_seq();
        let start = rig.to_robot.len();
        rig.send_with_seq(seq, Request::Ping { nonce });
        // Corrupt one byte inside every other frame (never the delimiter).
        if nonce % 2 == 0 {
            let len = rig.to_robot.len() - start;
            let at = start + rig.rng.range(0, len - 2);
            rig.to_robot[at] = rig.to_robot[at].wrapping_add(1).max(1);
        }
        frame.push(seq);
    }
    // And noise: random non-zero bytes, then a delimiter.
    for _ in 0..300 {
        let b = (rig.rng.next() as u8).max(1);
        rig.to_robot.push(b);
    }
    rig.to_robot.push(0);
    rig.run(30);
    for (i, &seq) in frame.iter().enumerate() {
        let got = rig.reply(seq);
        if i % 2 == 0 {
            assert_eq!(got, None, "a corrupted frame is not acted on");
        } else {
            assert_eq!(got, Some(Ok(Reply::Pong { nonce: i as u32 })));
        }
    }
    let Ok(Reply::Stats(stats)) = rig.ask(Request::GetStats) else {
        panic!("no stats");
    };
    assert_eq!(
        (stats.max_step_cycles, stats.stack_high_water_bytes),
        (0, 0),
        "a board that measures neither says 0, which the station shows as not measured"
    );
    let rx = stats.link.received;
    assert_eq!(rx.frames_ok, 11, "10 good pings and this GetStats");
    assert!(
        rx.dropped() >= 11,
        "10 corrupted frames and the noise: {rx:?}"
    );
    assert_eq!(
        rx.dropped(),
        rx.crc_errors + rx.format_errors + rx.overflows
    );
}

#[test]
fn a_frame_of_another_protocol_gets_version_mismatch() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let theirs = ProtocolId {
        version: PROTOCOL_VERSION + 1,
        schema_hash: 0xdead_beef,
    };
    let mut frame = [0u8; 64];
    let len = encode_raw(theirs, &[1, 2, 3], &mut frame).expect("fits");
    rig.to_robot.extend_from_slice(&frame[..len]);
    rig.run(3);
    assert!(rig
        .received
        .contains(&Uplink::VersionMismatch { received: theirs }));
}

#[test]
fn set_params_applies_a_valid_configuration_atomically() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let mut new = default_params();
    new.robot.track_width_m = 0.16;
    new.robot.wheel_radius_right_m = 0.033;
    new.supervisor.heartbeat_timeout_steps = 250;
    assert_eq!(
        rig.ask(Request::SetParams(new)),
        Ok(Reply::ParamsApplied {
            params_hash: params_hash(&new)
        })
    );
    // The control side uses it: the controller's geometry and the supervisor's settings.
    let controller = rig.control.controller();
    assert_eq!(controller.params().config().track_width_m, 0.16);
    assert_eq!(controller.params().geometry().wheel_radius_right_m(), 0.033);
    assert_eq!(
        rig.control.supervisor().config().heartbeat_timeout_steps,
        250
    );
    // The link side reports it.
    assert_eq!(rig.ask(Request::GetParams), Ok(Reply::Params(new)));
    let Ok(Reply::Info(info)) = rig.ask(Request::Info) else {
        panic!("no info");
    };
    assert_eq!(info.params_hash, params_hash(&new));
}

#[test]
fn invalid_params_are_refused_naming_the_field_and_change_nothing() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let mut bad = default_params();
    bad.robot.wheel_radius_left_m = -0.03;
    assert_eq!(
        rig.ask(Request::SetParams(bad)),
        Err(Refusal::InvalidParams(FieldProblem::new(
            "robot.wheel_radius_left_m",
            "must be > 0"
        )))
    );
    let mut bad = default_params();
    bad.supervisor.battery.fault_v = 4.0; // below the bridge's 4.5 V minimum
    assert_eq!(
        rig.ask(Request::SetParams(bad)),
        Err(Refusal::InvalidParams(FieldProblem::new(
            "supervisor.battery",
            "needs min supply ≤ fault_v ≤ warn_v"
        )))
    );
    assert_eq!(
        rig.ask(Request::GetParams),
        Ok(Reply::Params(default_params()))
    );
}

#[test]
fn set_params_while_armed_is_refused_and_nothing_changes() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    rig.heartbeat_every = Some(100);
    let arm = Request::Arm {
        mode: ArmMode::HoldWheelSpeeds(controller_core::kinematics::WheelSpeeds::new(3.0, 3.0)),
        initial_motion: None,
        run_time_limit_steps: None,
    };
    assert_eq!(rig.ask(arm), Ok(Reply::Ack));
    assert_eq!(rig.last.map(|a| a.state), Some(State::Armed));
    let before = *rig.control.controller().params();
    let mut new = default_params();
    new.robot.track_width_m = 0.2;
    assert_eq!(rig.ask(Request::SetParams(new)), Err(Refusal::Armed));
    assert_eq!(*rig.control.controller().params(), before);
    assert_eq!(
        rig.ask(Request::GetParams),
        Ok(Reply::Params(default_params()))
    );
    assert!(rig
        .events()
        .contains(&Event::Armed(RunMode::HoldWheelSpeeds)));
    // Disarmed, the same request is applied.
    assert_eq!(rig.ask(Request::Disarm), Ok(Reply::Ack));
    assert_eq!(
        rig.ask(Request::SetParams(new)),
        Ok(Reply::ParamsApplied {
            params_hash: params_hash(&new)
        })
    );
}

#[test]
fn the_telemetry_rate_is_checked_against_the_baud_rate() {
    let mut channels = Channels::new();
    // 115 200 baud carries 51 telemetry frames a second with 30 % kept free.
    let mut rig = Rig::new(&mut channels, 115_200, false);
    assert_eq!(rig.link.max_telemetry_hz(), 51);
    for hz in [0u8, 52, 101] {
        assert!(
            matches!(
                rig.ask(Request::SetTelemetryRate { hz }),
                Err(Refusal::InvalidArgument(FieldProblem { ref field, .. })) if field == "hz"
            ),
            "{hz} Hz"
        );
    }
    assert_eq!(
        rig.ask(Request::SetTelemetryRate { hz: 50 }),
        Ok(Reply::Ack)
    );
    let before = rig.telemetry().len();
    rig.run(1000);
    let samples = rig.telemetry();
    assert_eq!(samples.len() - before, 50, "50 samples in one second");
    // Samples are 20 steps apart and carry the step, the state and the supply.
    let last = samples[samples.len() - 1];
    let previous = samples[samples.len() - 2];
    assert_eq!(last.step - previous.step, 20);
    assert_eq!(last.state, State::Disarmed);
    assert!((last.supply_v - support::SUPPLY_V).abs() < 0.01);
}

#[test]
fn telemetry_is_dropped_when_the_line_is_stalled_but_replies_are_not() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    assert_eq!(
        rig.ask(Request::SetTelemetryRate { hz: 100 }),
        Ok(Reply::Ack)
    );
    rig.tx_paused = true;
    rig.run(300); // 30 samples; the stalled buffer takes only the first few
    let queued = rig.link.outgoing().len();
    assert!(queued > 0 && queued <= TX_CAPACITY);
    assert!(rig.link.counters().telemetry_dropped > 20);
    // Requests still get replies: a ping answered by the link side, a heartbeat answered
    // by the control side, a chunk acknowledged (refused: no upload).
    let ping = rig.send(Request::Ping { nonce: 5 });
    let heartbeat = rig.send(Request::Heartbeat);
    let chunk = rig.send(Request::PathChunk(link::PathChunk {
        upload_id: 9,
        first_index: 0,
        segments: heapless::Vec::new(),
    }));
    rig.run(50);
    rig.tx_paused = false;
    rig.run(5);
    assert_eq!(rig.reply(ping), Some(Ok(Reply::Pong { nonce: 5 })));
    assert_eq!(rig.reply(heartbeat), Some(Ok(Reply::Ack)));
    assert_eq!(
        rig.reply(chunk),
        Some(Err(Refusal::UnknownUpload { upload_id: 9 }))
    );
    assert_eq!(rig.link.counters().replies_dropped, 0);
    let Ok(Reply::Stats(stats)) = rig.ask(Request::GetStats) else {
        panic!("no stats");
    };
    assert!(stats.link.telemetry_dropped >= rig.link.counters().telemetry_dropped);
    // Counted before its own reply (and the telemetry after it) went out.
    assert!(stats.link.frames_sent < rig.link.counters().frames_sent);
    assert!(
        stats.link.frames_sent >= 5,
        "rate ack, a sample, pong, refusal, heartbeat ack"
    );
}

#[test]
fn a_full_command_queue_answers_busy_but_keeps_room_for_an_emergency_stop() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    // Requests straight into the link side, with no control step in between.
    let mut seqs = Vec::new();
    for _ in 0..4 {
        let seq = rig.send(Request::Heartbeat);
        seqs.push(seq);
    }
    let stop = rig.send(Request::EmergencyStop);
    rig.deliver_at_once();
    // Three heartbeats queued, the fourth refused: the last place is the stop's.
    assert_eq!(rig.reply(seqs[3]), Some(Err(Refusal::Busy)));
    assert_eq!(rig.link.counters().busy, 1);
    rig.run(10);
    for &seq in &seqs[..3] {
        assert_eq!(rig.reply(seq), Some(Ok(Reply::Ack)));
    }
    assert_eq!(rig.reply(stop), Some(Ok(Reply::Ack)));
    assert!(rig.events().contains(&Event::Faulted));
    assert_eq!(rig.last.map(|a| a.state), Some(State::Faulted));
    // Clearing works, and clearing again (a lost reply re-sent) is no error.
    assert_eq!(rig.ask(Request::ClearFaults), Ok(Reply::Ack));
    assert_eq!(rig.ask(Request::ClearFaults), Ok(Reply::Ack));
    assert_eq!(rig.last.map(|a| a.state), Some(State::Disarmed));
}

#[test]
fn a_tune_runs_and_reports_how_it_ended() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    rig.heartbeat_every = Some(100);
    // Before any tune: the empty report.
    assert_eq!(
        rig.ask(Request::GetTuneReport),
        Ok(Reply::TuneReport(link::TuneReport::NONE))
    );
    let tune = Request::Arm {
        mode: ArmMode::Tune,
        initial_motion: None,
        run_time_limit_steps: None,
    };
    assert_eq!(rig.ask(tune), Ok(Reply::Ack));
    rig.run(200);
    // Stopped by the link: the tune ends, and says so unasked.
    assert_eq!(rig.ask(Request::Disarm), Ok(Reply::Ack));
    rig.run(5);
    let reports: Vec<_> = rig
        .received
        .iter()
        .filter_map(|m| match m {
            Uplink::TuneReport(r) => Some(*r),
            _ => None,
        })
        .collect();
    let expected = link::TuneReport {
        tunes_ended: 1,
        outcome: Err(controller_core::tune::TuneAbort::Stopped),
    };
    assert_eq!(reports, [expected]);
    assert_eq!(
        rig.ask(Request::GetTuneReport),
        Ok(Reply::TuneReport(expected))
    );
    // A tune is no path run: no run report was sent.
    assert!(!rig
        .received
        .iter()
        .any(|m| matches!(m, Uplink::RunReport(_))));
}

#[test]
fn a_path_run_ends_with_its_report_computed_on_the_robot() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    rig.heartbeat_every = Some(100);
    // Before any run: an empty report.
    assert_eq!(
        rig.ask(Request::GetRunReport),
        Ok(Reply::RunReport(link::RunReport::default()))
    );
    let arm = Request::Arm {
        mode: ArmMode::FollowPath,
        initial_motion: None,
        run_time_limit_steps: None,
    };
    assert_eq!(rig.ask(arm), Ok(Reply::Ack));
    rig.run(1500);
    assert_eq!(rig.ask(Request::Disarm), Ok(Reply::Ack));
    rig.run(5);
    let reports: Vec<_> = rig
        .received
        .iter()
        .filter_map(|m| match m {
            Uplink::RunReport(r) => Some(*r),
            _ => None,
        })
        .collect();
    assert_eq!(reports.len(), 1, "one report per run, sent unasked");
    let report = reports[0];
    assert_eq!(report.runs_ended, 1);
    // Armed from the arm request's step to the step before the disarm: about 1.5 s.
    assert!(
        (1500..1600).contains(&report.run_steps),
        "{}",
        report.run_steps
    );
    // The 1 kHz robot steers at 100 Hz: one error sample per steering update.
    let expected_samples = report.run_steps / 10;
    assert!(
        report.estimated.samples.abs_diff(expected_samples) <= 1,
        "{report:?}"
    );
    assert!(
        report.max_duty > 0.0 && report.max_duty <= 1.0,
        "{report:?}"
    );
    assert!(report.max_wheel_speed_rad_s > 0.0, "{report:?}");
    // Asked again, the same report.
    assert_eq!(rig.ask(Request::GetRunReport), Ok(Reply::RunReport(report)));
    // A hold-speed run is not a path run: no new report. Armed once the wheels are at
    // rest (the run's end left them turning).
    rig.run(1000);
    let hold = Request::Arm {
        mode: ArmMode::HoldWheelSpeeds(controller_core::kinematics::WheelSpeeds::new(3.0, 3.0)),
        initial_motion: None,
        run_time_limit_steps: None,
    };
    assert_eq!(rig.ask(hold), Ok(Reply::Ack));
    rig.run(50);
    assert_eq!(rig.ask(Request::Disarm), Ok(Reply::Ack));
    assert_eq!(rig.ask(Request::GetRunReport), Ok(Reply::RunReport(report)));
}

#[test]
fn a_run_that_ends_while_the_uplink_is_full_still_wakes_the_link_and_sends_its_report() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let config = default_params().supervisor;
    let mut background = 0u32;
    // Control steps only, the link task never running: the uplink is not drained.
    let mut step = |rig: &mut Rig<'_>, button_pressed: bool| {
        background = background.wrapping_add(1);
        rig.control.step(robot_app::Sensors {
            ticks: controller_core::controller::TickDeltas::default(),
            periods: core::num::NonZeroU32::MIN,
            supply_v: support::SUPPLY_V,
            button_pressed,
            overrun: false,
            background_heartbeat: background,
            gyro: None,
        })
    };
    let mut press = |rig: &mut Rig<'_>, steps: u32| {
        let mut events = 0;
        for _ in 0..steps {
            events += usize::from(step(rig, true).event.is_some());
        }
        for _ in 0..2 * config.debounce_steps {
            events += usize::from(step(rig, false).event.is_some());
        }
        events
    };
    // Nine mode-select holds, each an event (the mode selected): eight fill the uplink,
    // and the ninth brings the mode round to path following again.
    let long = controller_core::supervisor::MODE_SELECT_FACTOR * config.long_press_steps
        + 2 * config.debounce_steps;
    let selected: usize = (0..9).map(|_| press(&mut rig, long)).sum();
    assert_eq!(selected, 9);
    assert_eq!(rig.control.supervisor().run_mode(), RunMode::FollowPath);
    // A short press arms (its event has no room either), and the run goes on for a while.
    press(&mut rig, 2 * config.debounce_steps);
    for _ in 0..20 {
        assert_eq!(step(&mut rig, false).state, State::Armed);
    }
    // The press that ends the run: its event is dropped, but the run's report is queued,
    // and the step says the link task has work.
    let mut ended = None;
    for _ in 0..2 * config.debounce_steps {
        let out = step(&mut rig, true);
        if out.state != State::Armed {
            ended = Some(out);
            break;
        }
    }
    let ended = ended.expect("the press disarmed");
    assert_eq!(
        ended.event,
        Some(Event::Disarmed(
            controller_core::supervisor::DisarmReason::Button
        ))
    );
    assert!(ended.link_has_work, "the run's report waits for the link");
    // The link task runs: the report goes out.
    rig.link.poll();
    rig.drain_tx();
    let reports: Vec<_> = rig
        .received
        .iter()
        .filter_map(|m| match m {
            Uplink::RunReport(r) => Some(*r),
            _ => None,
        })
        .collect();
    assert_eq!(reports.len(), 1, "{:?}", rig.received);
    assert_eq!(reports[0].runs_ended, 1);
    // The uplink held the first eight mode selections; the rest, the arming and the
    // disarming, found it full.
    let events = rig.events();
    assert_eq!(events.len(), 8, "{events:?}");
    assert!(events.iter().all(|e| matches!(e, Event::ModeSelected(_))));
}

#[test]
fn the_pose_command_sets_the_pose_while_disarmed_only_and_names_a_bad_field() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    rig.heartbeat_every = Some(100);
    let set = |x_m, y_m, theta_rad| Request::SetPose {
        x_m,
        y_m,
        theta_rad,
    };
    assert_eq!(rig.ask(set(0.5, -0.25, 1.0)), Ok(Reply::Ack));
    let pose = rig.control.controller().pose();
    assert_eq!((pose.x_m, pose.y_m), (0.5, -0.25));
    assert!((pose.theta_rad - 1.0).abs() < 1e-6, "{pose:?}");
    assert!(rig.events().contains(&Event::PoseSet));
    refuses_each_as_not_finite(
        &mut rig,
        [
            (set(f32::NAN, 0.0, 0.0), "x_m"),
            (set(0.0, f32::INFINITY, 0.0), "y_m"),
            (set(0.0, 0.0, f32::NEG_INFINITY), "theta_rad"),
        ],
    );
    assert_eq!(
        rig.control.controller().pose(),
        pose,
        "a refused pose changes nothing"
    );
    let arm = Request::Arm {
        mode: ArmMode::FollowPath,
        initial_motion: None,
        run_time_limit_steps: None,
    };
    assert_eq!(rig.ask(arm), Ok(Reply::Ack));
    assert_eq!(rig.ask(set(0.0, 0.0, 0.0)), Err(Refusal::Armed));
}

#[test]
fn an_arm_request_s_time_limit_holds_for_its_run_only_and_changes_no_setting() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    rig.heartbeat_every = Some(100);
    let before = rig.ask(Request::GetParams);
    let arm = |limit| Request::Arm {
        mode: ArmMode::HoldWheelSpeeds(controller_core::kinematics::WheelSpeeds::new(0.0, 0.0)),
        initial_motion: None,
        run_time_limit_steps: limit,
    };
    assert_eq!(rig.ask(arm(Some(300))), Ok(Reply::Ack));
    rig.run(400);
    assert_eq!(rig.control.supervisor().state(), State::Disarmed);
    assert!(rig.events().contains(&Event::Disarmed(
        controller_core::supervisor::DisarmReason::Timeout
    )));
    assert_eq!(rig.ask(Request::GetParams), before, "no setting changed");
    // The next run without a limit of its own has the stored one (none here).
    assert_eq!(rig.ask(arm(None)), Ok(Reply::Ack));
    rig.run(400);
    assert_eq!(rig.control.supervisor().state(), State::Armed);
}

#[test]
fn a_velocity_command_names_a_field_that_is_not_finite_and_needs_the_velocity_mode() {
    use link::NotPermitted;
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let velocity = |v_m_s, omega_rad_s| Request::Velocity { v_m_s, omega_rad_s };
    refuses_each_as_not_finite(
        &mut rig,
        [
            (velocity(f32::NAN, 0.0), "v_m_s"),
            (velocity(0.1, f32::INFINITY), "omega_rad_s"),
        ],
    );
    // Disarmed, a velocity is refused as outside the velocity mode, not as busy.
    assert_eq!(
        rig.ask(velocity(0.1, 0.0)),
        Err(Refusal::NotPermitted(NotPermitted::NotInVelocityMode))
    );
    // Armed in the velocity mode, it drives the wheels forward.
    rig.heartbeat_every = Some(50);
    assert_eq!(
        rig.ask(Request::Arm {
            mode: ArmMode::FollowVelocity,
            initial_motion: None,
            run_time_limit_steps: None,
        }),
        Ok(Reply::Ack)
    );
    assert_eq!(rig.ask(velocity(0.1, 0.0)), Ok(Reply::Ack));
    rig.run(300);
    let duty = rig.last.expect("stepped").duty;
    assert!(duty.left > 0.05 && duty.right > 0.05, "{duty:?}");
}

#[test]
fn a_second_configuration_before_the_first_is_installed_is_busy() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let mut first = default_params();
    first.supervisor.heartbeat_timeout_steps = 321;
    let mut second = default_params();
    second.supervisor.heartbeat_timeout_steps = 654;
    let a = rig.send(Request::SetParams(first));
    let b = rig.send(Request::SetParams(second));
    // Both straight into the link side, with no control step to install the first.
    rig.deliver_at_once();
    assert_eq!(rig.reply(b), Some(Err(Refusal::Busy)));
    rig.run(10);
    assert!(matches!(
        rig.reply(a),
        Some(Ok(Reply::ParamsApplied { .. }))
    ));
    let Ok(Reply::Params(active)) = rig.ask(Request::GetParams) else {
        panic!("no params");
    };
    assert_eq!(active.supervisor.heartbeat_timeout_steps, 321);
}

#[test]
fn a_stalled_line_keeps_room_for_the_largest_reply_and_every_forwarded_ones() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    assert_eq!(
        rig.ask(Request::SetTelemetryRate { hz: 100 }),
        Ok(Reply::Ack)
    );
    rig.tx_paused = true;
    rig.run(300);
    // Three requests for the control side and the largest reply the link side gives, in
    // one go, into a buffer that telemetry filled as far as it may.
    let heartbeats: Vec<u16> = (0..3).map(|_| rig.send(Request::Heartbeat)).collect();
    let params = rig.send(Request::GetParams);
    rig.run(20);
    rig.tx_paused = false;
    rig.run(5);
    for seq in heartbeats {
        assert_eq!(rig.reply(seq), Some(Ok(Reply::Ack)));
    }
    assert!(matches!(rig.reply(params), Some(Ok(Reply::Params(_)))));
    assert_eq!(rig.link.counters().replies_dropped, 0);
}
