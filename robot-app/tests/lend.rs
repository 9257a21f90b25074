//! Installs, arming's end and a run's report out of the control step
//! (`robot_app::lend`): the control side lent to the link task's borrower between two
//! steps, the stopped steps while it is away, and the step's own fallback when nobody
//! does the work between steps.

mod support;

use core::num::NonZeroU32;

use controller_core::controller::{MotorCommand, TickDeltas};
use controller_core::supervisor::{Bridge, State};
use link::{encode, params_hash, Decoder, Downlink, Received, Reply, Request, RunReport, Uplink};
use robot_app::{
    start, Actuation, Borrower, Channels, ControlRoom, ControlSeat, ControlSide, LinkService,
    NoBoardStats, Sensors,
};
use support::{app_config, default_params, SUPPLY_V};

const BAUD: u32 = 921_600;

/// A configuration that differs from the default one in the track width.
fn new_params() -> link::ParamSet {
    let mut params = default_params();
    params.robot.track_width_m = 0.16;
    params
}

/// Frames `request` under `seq` into the link side.
fn send(link: &mut LinkService<'_>, seq: u16, request: Request) {
    let mut frame = [0u8; link::MAX_FRAME_LEN];
    let len = encode(&Downlink { seq, request }, &mut frame).expect("encodable");
    assert_eq!(link.receive(&frame[..len], &NoBoardStats), len);
}

/// The reply to `seq` among what the link side has queued (consumed).
fn reply(link: &mut LinkService<'_>, host: &mut Decoder, seq: u16) -> Option<Reply> {
    let bytes = link.outgoing().to_vec();
    link.consume(bytes.len());
    host.feed::<Uplink>(&bytes).find_map(|m| match m {
        Ok(Received::Message(Uplink::Reply { seq: s, result })) if s == seq => result.ok(),
        _ => None,
    })
}

/// An on-time step at rest with `ticks`.
fn sensors(left: i32, right: i32) -> Sensors {
    Sensors {
        ticks: TickDeltas { left, right },
        ..Sensors::at_rest(SUPPLY_V)
    }
}

/// A robot with the default configuration, seated in `room`: its seat and borrower, and
/// its link side.
fn seated<'a>(
    channels: &'a mut Channels,
    room: &'a mut ControlRoom<'a>,
) -> (ControlSeat<'a>, Borrower<'a>, LinkService<'a>) {
    let (control, link) = start(channels, app_config(BAUD, false)).expect("valid");
    let (seat, borrower) = room.seat(control);
    (seat, borrower, link)
}

#[test]
fn an_install_runs_in_the_borrower_between_two_steps() {
    let (mut channels, mut room) = (Channels::new(), ControlRoom::new());
    let (mut seat, mut borrower, mut link) = seated(&mut channels, &mut room);
    let mut host = Decoder::new();
    assert!(!borrower.run(), "nothing lent yet");

    send(&mut link, 7, Request::SetParams(new_params()));
    link.poll();
    let out = seat.step(Sensors::at_rest(SUPPLY_V));
    assert!(out.lend_due && out.link_has_work);
    assert!(seat.control().is_none(), "lent to the borrower");
    // Not installed in the step: the borrower does it.
    assert!(borrower.run());
    assert!(!borrower.run(), "handed back");
    let out = seat.step(Sensors::at_rest(SUPPLY_V));
    assert!(!out.lend_due);
    link.poll();
    assert_eq!(
        reply(&mut link, &mut host, 7),
        Some(Reply::ParamsApplied {
            params_hash: params_hash(&new_params())
        })
    );
    let control = seat.control().expect("back");
    assert_eq!(control.controller().params().config().track_width_m, 0.16);
    assert_eq!(out.missed_ticks_total, 0, "no step was missed");
}

/// A seated robot and a direct one, both disarmed, each with the same install request
/// taken by its first step (ticks `first`); the direct one has installed.
fn lending_and_direct<'a>(
    channels: &'a mut Channels,
    room: &'a mut ControlRoom<'a>,
    channels_2: &'a mut Channels,
    first: Sensors,
) -> (ControlSeat<'a>, Borrower<'a>, ControlSide<'a>, Actuation) {
    let (mut seat, borrower, mut link) = seated(channels, room);
    let (mut direct, mut link_2) = start(channels_2, app_config(BAUD, false)).expect("valid");
    send(&mut link, 7, Request::SetParams(new_params()));
    link.poll();
    send(&mut link_2, 7, Request::SetParams(new_params()));
    link_2.poll();
    let lending = seat.step(first);
    assert!(lending.lend_due && direct.step(first).lend_due);
    assert!(direct.work_between_steps());
    (seat, borrower, direct, lending)
}

#[test]
fn while_the_control_side_is_away_the_motors_stay_stopped_and_no_tick_is_lost() {
    // Pushed by hand along +x: the install comes back three steps late on one robot,
    // between two steps on the other.
    let (mut channels, mut channels_2) = (Channels::new(), Channels::new());
    let mut room = ControlRoom::new();
    let (mut seat, mut borrower, mut direct, lending) =
        lending_and_direct(&mut channels, &mut room, &mut channels_2, sensors(3, 3));
    let pushes = [sensors(5, 5), sensors(2, 2), sensors(7, 7)];
    for push in pushes {
        let out = seat.step(push);
        assert_eq!(out.duty, MotorCommand::STOP);
        assert_eq!(out.bridge, lending.bridge, "as the lending step left it");
        assert_eq!(out.state, State::Disarmed);
        assert_eq!(out.event, None);
        assert!(out.feed_watchdog);
        assert!(out.link_has_work, "the link task must run to give it back");
        assert!(!out.lend_due && !out.steering_lent);
        assert!(seat.control().is_none());
        direct.step(push);
    }
    assert!(borrower.run());
    let back = seat.step(sensors(1, 1));
    let out = direct.step(sensors(1, 1));
    let (lent_pose, direct_pose) = (
        seat.control().expect("back").controller().pose(),
        direct.controller().pose(),
    );
    assert!(direct_pose.x_m > 0.0);
    assert!(
        (lent_pose.x_m - direct_pose.x_m).abs() < 1e-6 && lent_pose.y_m == direct_pose.y_m,
        "odometry got every tick: {lent_pose:?} against {direct_pose:?}"
    );
    assert_eq!(back.missed_ticks_total, 3, "the stopped steps were missed");
    assert_eq!(out.missed_ticks_total, 0);
    assert_eq!(back.state, State::Disarmed, "a short gap is no fault");
    assert_eq!(
        seat.control()
            .expect("back")
            .controller()
            .params()
            .config()
            .track_width_m,
        0.16
    );
}

#[test]
fn a_control_side_kept_away_stops_feeding_the_watchdog_and_faults_when_back() {
    let (mut channels, mut channels_2) = (Channels::new(), Channels::new());
    let mut room = ControlRoom::new();
    let (mut seat, mut borrower, direct, _) = lending_and_direct(
        &mut channels,
        &mut room,
        &mut channels_2,
        Sensors::at_rest(SUPPLY_V),
    );
    let feed_steps = direct.supervisor().config().background_timeout_steps;
    let fed: Vec<bool> = (0..feed_steps + 2)
        .map(|_| seat.step(Sensors::at_rest(SUPPLY_V)).feed_watchdog)
        .collect();
    assert_eq!(
        fed.iter().filter(|&&f| f).count() as u32,
        feed_steps,
        "fed as long as a starved background task would be"
    );
    assert_eq!(fed[..2], [true, true]);
    assert_eq!(fed[fed.len() - 2..], [false, false]);
    assert!(borrower.run());
    let back = seat.step(Sensors::at_rest(SUPPLY_V));
    assert_eq!(back.state, State::Faulted, "the gap is a missed-tick fault");
    assert!(back
        .faults
        .has(controller_core::supervisor::Fault::MissedTicks));
    assert_eq!(back.bridge, Bridge::Coast);
}

#[test]
fn a_step_installs_itself_what_nobody_installed_between_steps() {
    let mut channels = Channels::new();
    let (mut control, mut link): (ControlSide<'_>, _) =
        start(&mut channels, app_config(BAUD, false)).expect("valid");
    let mut host = Decoder::new();
    send(&mut link, 9, Request::SetParams(new_params()));
    link.poll();
    assert!(control.step(Sensors::at_rest(SUPPLY_V)).lend_due);
    let before = default_params().robot.track_width_m;
    assert_eq!(control.controller().params().config().track_width_m, before);
    control.step(Sensors {
        periods: NonZeroU32::MIN,
        ..Sensors::at_rest(SUPPLY_V)
    });
    assert_eq!(control.controller().params().config().track_width_m, 0.16);
    assert!(!control.work_between_steps(), "done already");
    link.poll();
    assert!(matches!(
        reply(&mut link, &mut host, 9),
        Some(Reply::ParamsApplied { .. })
    ));
}

#[test]
fn arming_is_finished_by_the_borrower_and_the_next_step_drives() {
    let (mut channels, mut room) = (Channels::new(), ControlRoom::new());
    let (mut seat, mut borrower, mut link) = seated(&mut channels, &mut room);
    let mut host = Decoder::new();
    send(
        &mut link,
        3,
        Request::Arm {
            mode: link::ArmMode::FollowPath,
            initial_motion: None,
        },
    );
    link.poll();
    let out = seat.step(Sensors::at_rest(SUPPLY_V));
    assert_eq!(out.state, State::Armed);
    assert_eq!((out.duty, out.bridge), (MotorCommand::STOP, Bridge::Coast));
    assert!(out.lend_due && out.link_has_work);
    assert!(seat.control().is_none(), "lent to the borrower");
    assert!(borrower.run());
    let mut steered = 0;
    for k in 0..200 {
        let out = seat.step(Sensors::at_rest(SUPPLY_V));
        assert_eq!(
            (out.state, out.bridge),
            (State::Armed, Bridge::Drive),
            "step {k}"
        );
        assert!(!out.lend_due);
        let control = seat.control().expect("here");
        steered += u32::from(control.controller().telemetry().steering_updated);
        if k == 0 {
            assert!(!control.supervisor().arming_unfinished());
        }
    }
    assert!(steered > 10, "the steering law ran {steered} times");
    link.poll();
    assert!(reply(&mut link, &mut host, 3).is_some());
}

/// The run reports among what the link side has queued (consumed).
fn run_reports(link: &mut LinkService<'_>, host: &mut Decoder) -> Vec<RunReport> {
    link.poll();
    let bytes = link.outgoing().to_vec();
    link.consume(bytes.len());
    host.feed::<Uplink>(&bytes)
        .filter_map(|m| match m {
            Ok(Received::Message(Uplink::RunReport(report))) => Some(report),
            _ => None,
        })
        .collect()
}

/// Arms `link`'s robot to follow the path, runs it `steps` steps and disarms it, through
/// `step` (a seat's or a direct control side's step) and `between` (the work between
/// steps, after the step that arms); returns the step that disarms.
fn run_and_disarm(
    link: &mut LinkService<'_>,
    steps: u32,
    mut step: impl FnMut() -> Actuation,
    mut between: impl FnMut(),
) -> Actuation {
    send(
        link,
        3,
        Request::Arm {
            mode: link::ArmMode::FollowPath,
            initial_motion: None,
        },
    );
    link.poll();
    assert_eq!(step().state, State::Armed);
    between();
    for _ in 0..steps {
        let out = step();
        assert_eq!(out.state, State::Armed);
        assert!(!out.lend_due);
    }
    send(link, 4, Request::Disarm);
    link.poll();
    let out = step();
    assert_eq!(out.state, State::Disarmed);
    out
}

/// [`run_and_disarm`] on a control side stepped directly, with the work between steps
/// after arming done (`between`) or left to the next step.
fn run_and_disarm_direct(
    control: &mut ControlSide<'_>,
    link: &mut LinkService<'_>,
    between: bool,
) -> Actuation {
    let control = core::cell::RefCell::new(control);
    run_and_disarm(
        link,
        100,
        || control.borrow_mut().step(Sensors::at_rest(SUPPLY_V)),
        || {
            if between {
                assert!(control.borrow_mut().work_between_steps());
            }
        },
    )
}

#[test]
fn a_run_s_report_is_built_by_the_borrower_not_by_the_step_that_ends_the_run() {
    let (mut channels, mut room) = (Channels::new(), ControlRoom::new());
    let (mut seat, mut borrower, mut link) = seated(&mut channels, &mut room);
    let mut host = Decoder::new();
    let seat_cell = core::cell::RefCell::new(&mut seat);
    let out = run_and_disarm(
        &mut link,
        300,
        || seat_cell.borrow_mut().step(Sensors::at_rest(SUPPLY_V)),
        || assert!(borrower.run()),
    );
    assert!(out.lend_due && out.link_has_work);
    assert!(
        run_reports(&mut link, &mut host).is_empty(),
        "not built in the step"
    );
    assert!(borrower.run());
    let reports = run_reports(&mut link, &mut host);
    assert_eq!(reports.len(), 1);
    assert_eq!(reports[0].runs_ended, 1);
    assert!(reports[0].run_steps >= 300, "{:?}", reports[0]);
    let out = seat.step(Sensors::at_rest(SUPPLY_V));
    assert!(!out.lend_due, "reported once");
    assert!(run_reports(&mut link, &mut host).is_empty());
}

#[test]
fn a_step_reports_itself_a_run_nobody_reported_between_steps() {
    let mut channels = Channels::new();
    let (mut control, mut link): (ControlSide<'_>, _) =
        start(&mut channels, app_config(BAUD, false)).expect("valid");
    let mut host = Decoder::new();
    assert!(run_and_disarm_direct(&mut control, &mut link, false).lend_due);
    assert!(run_reports(&mut link, &mut host).is_empty());
    let out = control.step(Sensors::at_rest(SUPPLY_V));
    assert!(!out.lend_due);
    let reports = run_reports(&mut link, &mut host);
    assert_eq!(reports.len(), 1);
    assert_eq!(reports[0].runs_ended, 1);
    assert!(!control.work_between_steps(), "done already");
}

#[test]
fn work_between_steps_builds_a_finished_run_s_report_and_says_so() {
    let mut channels = Channels::new();
    let (mut control, mut link): (ControlSide<'_>, _) =
        start(&mut channels, app_config(BAUD, false)).expect("valid");
    let mut host = Decoder::new();
    assert!(run_and_disarm_direct(&mut control, &mut link, true).lend_due);
    assert!(control.work_between_steps(), "the report was due");
    assert_eq!(run_reports(&mut link, &mut host).len(), 1);
    assert!(!control.work_between_steps(), "nothing left");
}
