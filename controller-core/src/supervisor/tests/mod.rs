//! The supervisor against a controller on a straight line and a fake world.

use super::*;
use crate::controller::TickDeltas;
use crate::kinematics::{BodyVelocity, Pose, WheelSpeeds};
use crate::tune::TuneAbort;

const HOLD: WheelSpeeds = WheelSpeeds {
    left_rad_s: 5.0,
    right_rad_s: 5.0,
};
const START: Pose = Pose {
    x_m: 0.0,
    y_m: -0.2,
    theta_rad: 0.0,
};

fn controller() -> Controller {
    crate::controller::tests::on_a_line(3.0)
}

/// The defaults, except the saturation check: the rig's fake world turns the wheels at a
/// fixed speed (or not at all), whatever the loops ask, so the loops sit at their limits
/// in most tests. `a_loop_stuck_at_its_limits_faults` checks it on its own.
fn config() -> SupervisorConfig {
    let mut c = SupervisorConfig::at_rate(1000, START, HOLD);
    c.saturation.max_fraction = 1.0;
    c
}

fn params() -> Params {
    *controller().params()
}

/// The supply of the rig, V.
const SUPPLY_V: f32 = 6.0;

/// A supervisor and a controller, with a fake world: each step the heartbeat moves,
/// and in `moving` the wheels turn at the held speed (5 rad/s ≈ 1.15 ticks/ms).
struct Rig {
    sup: Supervisor,
    ctl: Controller,
    heartbeat: u32,
    button: bool,
    overrun: bool,
    supply_v: f32,
    periods: NonZeroU32,
    command: Option<Command>,
    background_alive: bool,
    moving: bool,
    ticks_acc: f32,
    steps: u32,
    /// The gyro's reading each step (`None`: no IMU).
    gyro: Option<crate::gyro::GyroSample>,
}

impl Rig {
    /// The robot put down at [`START`], 0.2 m beside the line, and told so.
    fn new(config: SupervisorConfig, reset: ResetCause) -> Self {
        let mut sup = Supervisor::new(config, &params(), reset).unwrap();
        let mut ctl = controller();
        assert_eq!(sup.set_pose(&mut ctl, START), Ok(Event::PoseSet));
        Self {
            sup,
            ctl,
            heartbeat: 0,
            button: false,
            overrun: false,
            supply_v: SUPPLY_V,
            periods: NonZeroU32::MIN,
            command: None,
            background_alive: true,
            moving: false,
            ticks_acc: 0.0,
            steps: 0,
            gyro: None,
        }
    }

    fn step_with(&mut self, ticks: TickDeltas) -> SupervisorOutput {
        if self.background_alive {
            self.heartbeat = self.heartbeat.wrapping_add(1);
        }
        self.steps += 1;
        let input = Inputs {
            ticks,
            periods: self.periods,
            supply_v: self.supply_v,
            button_pressed: self.button,
            overrun: self.overrun,
            background_heartbeat: self.heartbeat,
            command: self.command.take(),
            gyro: self.gyro,
        };
        self.sup.step(&mut self.ctl, input)
    }

    fn step(&mut self) -> SupervisorOutput {
        let mut ticks = TickDeltas::default();
        if self.moving {
            // 5 rad/s × 1 ms / (2π / 1440 rad per tick) ≈ 1.146 ticks per step.
            self.ticks_acc += 5.0 * 0.001 * 1440.0 / core::f32::consts::TAU;
            let whole = self.ticks_acc as i32;
            self.ticks_acc -= whole as f32;
            ticks = TickDeltas {
                left: whole,
                right: whole,
            };
        }
        self.step_with(ticks)
    }

    /// Runs `n` steps, returning every output.
    fn run(&mut self, n: u32) -> Vec<SupervisorOutput> {
        (0..n).map(|_| self.step()).collect()
    }

    /// Presses for `held` steps then releases for 50 steps; returns all outputs.
    /// [`SHORT`], [`LONG`] and [`MODE_SELECT`] are the three kinds of press.
    fn press(&mut self, held: u32) -> Vec<SupervisorOutput> {
        self.button = true;
        let mut out = self.run(held);
        self.button = false;
        out.extend(self.run(50));
        out
    }
}

/// A short press (released before the 1 s long press, with its debounce).
const SHORT: u32 = 30;
/// A long press: released after 1 s, before the 3 s mode-select hold.
const LONG: u32 = 1200;
/// Held to the 3 s mode-select hold.
const MODE_SELECT: u32 = 3100;

fn events(outs: &[SupervisorOutput]) -> Vec<Event> {
    outs.iter().filter_map(|o| o.event).collect()
}

fn rig() -> Rig {
    Rig::new(config(), ResetCause::PowerOn)
}

/// A rig whose fake world turns both wheels at 5 rad/s, for tests of arming and the
/// link. Following the line from 0.2 m beside it asks the left wheel to turn slower than
/// that, so its loop brakes against a wheel the world keeps turning: by the stall check's
/// rule a stall, which these tests keep out of the way.
fn moving_rig() -> Rig {
    let mut c = config();
    c.stall.timeout_steps = u32::MAX;
    let mut r = Rig::new(c, ResetCause::PowerOn);
    r.moving = true;
    r
}

#[test]
fn starts_disarmed_with_motors_off_and_feeds_the_watchdog() {
    let mut r = rig();
    for out in r.run(3000) {
        assert_eq!(out.state, State::Disarmed);
        assert_eq!(out.duty, MotorCommand::STOP);
        assert_eq!(out.bridge, Bridge::Coast);
        assert!(out.feed_watchdog);
        assert_eq!(out.event, None);
    }
    assert_eq!(r.ctl.mode(), Mode::Idle);
}

#[test]
fn starts_disarmed_after_any_reset_cause() {
    for cause in [
        ResetCause::PowerOn,
        ResetCause::BrownOut,
        ResetCause::Pin,
        ResetCause::Watchdog,
        ResetCause::Software,
        ResetCause::LowPower,
        ResetCause::Unknown,
    ] {
        let mut c = config();
        c.auto_arm_after_steps = Some(10);
        let sup = Supervisor::new(c, &params(), cause).unwrap();
        assert_eq!(sup.state(), State::Disarmed);
    }
}

#[test]
fn short_press_arms_on_release_in_the_initial_mode() {
    let mut r = rig();
    r.button = true;
    // Still disarmed while the button is held.
    for out in r.run(200) {
        assert_eq!(out.state, State::Disarmed);
    }
    r.button = false;
    let outs = r.run(50);
    assert_eq!(events(&outs), vec![Event::Armed(RunMode::FollowPath)]);
    let last = outs.last().unwrap();
    assert_eq!(last.state, State::Armed);
    assert_eq!(last.bridge, Bridge::Drive);
    assert_eq!(r.ctl.mode(), Mode::FollowPath);
    // The line is ahead: the robot drives forward.
    assert!(last.duty.left > 0.0 && last.duty.right > 0.0);
    assert_eq!(last.duty, last.controller_duty);
}

#[test]
fn arming_keeps_the_pose_and_a_long_press_sets_it_to_the_start() {
    let mut r = rig();
    // Odometry counts while the robot is pushed away, then stands still.
    for _ in 0..100 {
        r.step_with(TickDeltas { left: 3, right: 1 });
    }
    r.run(200);
    let pushed = r.ctl.pose();
    assert!(pushed.x_m > 0.01);
    // A short press arms from where it is.
    let outs = r.press(SHORT);
    assert_eq!(events(&outs), vec![Event::Armed(RunMode::FollowPath)]);
    assert!(
        (r.ctl.pose().x_m - pushed.x_m).abs() < 0.05,
        "{:?}",
        r.ctl.pose()
    );
    // Disarmed and put back at the start: a long press tells it so, and does not arm.
    r.press(SHORT);
    r.run(200);
    let outs = r.press(LONG);
    assert_eq!(events(&outs), vec![Event::PoseSet]);
    assert_eq!(r.sup.state(), State::Disarmed);
    let pose = r.ctl.pose();
    assert!((pose.x_m - START.x_m).abs() < 1e-6 && (pose.y_m - START.y_m).abs() < 1e-6);
}

#[test]
fn bounces_shorter_than_the_debounce_time_do_nothing() {
    let mut r = rig();
    for _ in 0..50 {
        r.button = true;
        r.run(5);
        r.button = false;
        r.run(5);
    }
    assert_eq!(r.sup.state(), State::Disarmed);
}

#[test]
fn press_disarms_at_once_and_its_release_does_not_rearm() {
    let mut r = rig();
    r.press(30);
    assert_eq!(r.sup.state(), State::Armed);
    r.button = true;
    let outs = r.run(30);
    // Disarmed as soon as the press is debounced (20 steps), with the button still down.
    let at = outs
        .iter()
        .position(|o| o.state == State::Disarmed)
        .unwrap();
    assert_eq!(at, 19);
    assert_eq!(outs[at].event, Some(Event::Disarmed(DisarmReason::Button)));
    assert_eq!(outs[at].duty, MotorCommand::STOP);
    assert_eq!(outs[at].bridge, Bridge::Brake);
    r.button = false;
    assert!(r.run(200).iter().all(|o| o.state == State::Disarmed));
    assert_eq!(r.ctl.mode(), Mode::Idle);
}

#[test]
fn a_mode_select_hold_while_disarmed_switches_mode_without_arming() {
    let mut r = rig();
    let outs = r.press(MODE_SELECT);
    assert_eq!(
        events(&outs),
        vec![Event::ModeSelected(RunMode::HoldWheelSpeeds)]
    );
    assert_eq!(r.sup.state(), State::Disarmed);
    // A short press now arms into wheel-speed hold.
    let outs = r.press(30);
    assert_eq!(events(&outs), vec![Event::Armed(RunMode::HoldWheelSpeeds)]);
    assert_eq!(r.ctl.mode(), Mode::HoldWheelSpeeds(HOLD));
    assert!(outs.last().unwrap().duty.left > 0.0);
    // Disarm; a second hold selects the tune, a third path following again.
    r.press(30);
    let outs = r.press(MODE_SELECT);
    assert_eq!(events(&outs), vec![Event::ModeSelected(RunMode::Tune)]);
    let outs = r.press(MODE_SELECT);
    assert_eq!(
        events(&outs),
        vec![Event::ModeSelected(RunMode::FollowPath)]
    );
}

/// Mode-select holds until the tune is selected, then a short press: armed in tune mode.
fn arm_tune_by_button(r: &mut Rig) -> Vec<SupervisorOutput> {
    r.press(MODE_SELECT);
    r.press(MODE_SELECT);
    assert_eq!(r.sup.run_mode(), RunMode::Tune);
    let outs = r.press(30);
    assert!(events(&outs).contains(&Event::Armed(RunMode::Tune)));
    outs
}

#[test]
fn the_tune_drives_rising_volts_open_loop_and_a_fault_stops_it() {
    let mut r = rig();
    arm_tune_by_button(&mut r);
    // The rig's wheels do not turn: the tune's breakaway ramp keeps rising (0.5 V/s).
    let outs = r.run(500);
    assert!(outs.iter().all(|o| o.state == State::Armed));
    assert!(matches!(r.ctl.mode(), Mode::ApplyVolts(_)));
    let volts = r.ctl.telemetry().wheel_loop.volts;
    assert!((volts.left_v - 0.265).abs() < 0.01, "{volts:?}");
    assert_eq!(volts.left_v, volts.right_v);
    assert!(outs.windows(2).all(|w| w[1].duty.left >= w[0].duty.left));
    // A fault (the link's emergency stop) ends it: motors off, the tune stopped.
    let out = r.command(Command::EmergencyStop);
    assert_eq!(out.state, State::Faulted);
    assert_eq!(out.duty, MotorCommand::STOP);
    assert_eq!(r.sup.tune_outcome(), Some(Err(TuneAbort::Stopped)));
    assert!(r.run(100).iter().all(|o| o.duty == MotorCommand::STOP));
}

#[test]
fn a_detected_fault_stops_the_tune_too() {
    let mut r = rig();
    arm_tune_by_button(&mut r);
    r.run(300);
    assert!(r.sup.tune_outcome().is_none());
    // The supply collapses: the supervisor's own check faults, the tune ends with it.
    r.supply_v = 4.4;
    let outs = r.run(600);
    let last = outs.last().unwrap();
    assert!(last.faults.has(Fault::SupplyLow));
    assert_eq!(last.state, State::Faulted);
    assert_eq!(last.duty, MotorCommand::STOP);
    assert_eq!(r.sup.tune_outcome(), Some(Err(TuneAbort::Stopped)));
    // Clearing the fault does not resume it: a new tune needs a new arm.
    r.supply_v = SUPPLY_V;
    r.run(50);
    assert!(r.run(100).iter().all(|o| o.duty == MotorCommand::STOP));
}

#[test]
fn a_tune_that_finds_nothing_disarms_with_its_reason() {
    let mut c = config();
    c.stall.timeout_steps = u32::MAX;
    let mut r = Rig::new(c, ResetCause::PowerOn);
    // The link arms the tune (heartbeats due).
    let out = r.command(Command::Arm(ArmRequest {
        mode: RunMode::Tune,
        hold_speeds: None,
        initial_motion: None,
        max_armed_steps: None,
    }));
    assert_eq!(out.event, Some(Event::Armed(RunMode::Tune)));
    let mut outs = Vec::new();
    for _ in 0..27 {
        outs.extend(r.run(399));
        r.command(Command::Heartbeat);
    }
    // The wheels never turn: at the largest voltage (4.8 V, 9.6 s of the ramp) plus 0.5 s
    // the tune gives up, the supervisor disarms and brakes.
    let at = outs
        .iter()
        .position(|o| o.state == State::Disarmed)
        .expect("disarmed");
    assert!((10_050..10_150).contains(&at), "{at}");
    assert_eq!(
        outs[at].event,
        Some(Event::Disarmed(DisarmReason::TuneFinished))
    );
    assert_eq!(outs[at].bridge, Bridge::Brake);
    assert!(outs[..at]
        .iter()
        .all(|o| o.duty.left * 6.0 <= 4.8 + 1e-3 && o.duty.left >= 0.0));
    assert_eq!(
        r.sup.tune_outcome(),
        Some(Err(TuneAbort::NoBreakaway(crate::tune::Side::Left)))
    );
}

#[test]
fn a_long_press_or_a_hold_while_armed_only_disarms() {
    for held in [LONG, MODE_SELECT] {
        let mut r = rig();
        r.press(SHORT);
        let outs = r.press(held);
        assert_eq!(events(&outs), vec![Event::Disarmed(DisarmReason::Button)]);
        assert_eq!(r.sup.run_mode(), RunMode::FollowPath);
    }
}

#[test]
fn core_fault_stops_the_motors_until_acknowledged() {
    let mut r = rig();
    r.press(30);
    assert!(r.step().duty.left > 0.0);
    let out = r.step_with(TickDeltas {
        left: 10_000,
        right: 0,
    });
    assert_eq!(out.event, Some(Event::Faulted));
    assert_eq!(out.state, State::Faulted);
    assert!(out.faults.has(Fault::EncoderJump));
    assert_eq!(out.duty, MotorCommand::STOP);
    assert_eq!(out.bridge, Bridge::Brake);
    // Latched, still fed (the fault is handled; a reset would hide it).
    for out in r.run(500) {
        assert_eq!(out.state, State::Faulted);
        assert_eq!(out.duty, MotorCommand::STOP);
        assert!(out.feed_watchdog);
    }
    // A press acknowledges: Disarmed, not Armed.
    let outs = r.press(30);
    assert_eq!(events(&outs), vec![Event::FaultsCleared]);
    assert_eq!(r.sup.state(), State::Disarmed);
    assert!(!r.sup.faults().any());
    assert!(!r.ctl.faults().any());
    // A second press arms again.
    r.press(30);
    assert_eq!(r.sup.state(), State::Armed);
}

#[test]
fn fault_while_disarmed_is_latched_too() {
    let mut r = rig();
    let out = r.step_with(TickDeltas {
        left: 0,
        right: -10_000,
    });
    assert_eq!(out.state, State::Faulted);
    // A press only acknowledges, it does not arm.
    r.press(30);
    assert_eq!(r.sup.state(), State::Disarmed);
}

#[test]
fn non_finite_pose_is_a_fault() {
    let mut r = rig();
    r.press(30);
    r.ctl.set_pose(Pose {
        x_m: f32::NAN,
        y_m: 0.0,
        theta_rad: 0.0,
    });
    let out = r.step();
    assert_eq!(out.state, State::Faulted);
    assert!(out.faults.has(Fault::NonFinite));
    assert_eq!(out.duty, MotorCommand::STOP);
}

#[test]
fn sporadic_overruns_are_counted_but_tolerated() {
    let mut r = rig();
    r.press(30);
    for _ in 0..10 {
        r.overrun = true;
        let out = r.step();
        assert!(out.feed_watchdog);
        r.overrun = false;
        r.run(10);
    }
    let out = r.step();
    assert_eq!(out.state, State::Armed);
    assert_eq!(out.overruns_total, 10);
}

#[test]
fn consecutive_overruns_fault_and_starve_the_watchdog() {
    let mut r = rig();
    r.press(30);
    r.overrun = true;
    let outs = r.run(5);
    assert!(outs[..4].iter().all(|o| o.feed_watchdog));
    assert!(outs[..4].iter().all(|o| o.state == State::Armed));
    let last = outs[4];
    assert!(!last.feed_watchdog);
    assert!(last.faults.has(Fault::Overrun));
    assert_eq!(last.state, State::Faulted);
    assert_eq!(last.duty, MotorCommand::STOP);
    // The loop recovers: feeding resumes, the fault stays latched.
    r.overrun = false;
    let out = r.step();
    assert!(out.feed_watchdog);
    assert_eq!(out.state, State::Faulted);
}

#[test]
fn starved_background_stops_the_feeding_but_not_the_motors() {
    let mut r = rig();
    // Hold mode, where the fake world turns the wheels at the held speed.
    r.long_press_to_hold();
    r.press(30);
    r.moving = true;
    r.background_alive = false;
    let outs = r.run(600);
    // Heartbeat last changed at step 0 of this run: the 500th unchanged step starves.
    assert!(outs[..499].iter().all(|o| o.feed_watchdog));
    assert!(outs[499..].iter().all(|o| !o.feed_watchdog));
    // The watchdog, not the supervisor, deals with it: the motors still run until reset.
    assert_eq!(outs[599].state, State::Armed, "{:?}", outs[599].faults);
    r.background_alive = true;
    assert!(r.step().feed_watchdog);
}

#[test]
fn a_wheel_that_does_not_turn_is_a_stall_fault() {
    let mut c = config();
    c.stall.min_volts = 1.0;
    let mut r = Rig::new(c, ResetCause::PowerOn);
    r.long_press_to_hold();
    r.press(30);
    assert_eq!(r.sup.state(), State::Armed);
    // Wheels blocked: no ticks while the PID pushes.
    let outs = r.run(1000);
    let at = outs
        .iter()
        .position(|o| o.state == State::Faulted)
        .expect("stall detected");
    assert!(at < 600, "stall at step {at}");
    assert!(outs[at].faults.has(Fault::StallLeft) && outs[at].faults.has(Fault::StallRight));
    assert_eq!(outs[at].duty, MotorCommand::STOP);
}

#[test]
fn a_wheel_that_turns_is_not_a_stall() {
    let mut c = config();
    c.stall.min_volts = 1.0;
    let mut r = Rig::new(c, ResetCause::PowerOn);
    r.long_press_to_hold();
    r.press(30);
    r.moving = true;
    let outs = r.run(3000);
    assert!(outs.iter().all(|o| o.state == State::Armed));
    assert!(outs.last().unwrap().duty.left > 0.0);
}

impl Rig {
    fn long_press_to_hold(&mut self) {
        self.press(MODE_SELECT);
        assert_eq!(self.sup.run_mode(), RunMode::HoldWheelSpeeds);
    }
}

#[test]
fn auto_arm_after_power_on_only_once() {
    let mut c = config();
    c.auto_arm_after_steps = Some(2000);
    let mut r = Rig::new(c, ResetCause::PowerOn);
    let outs = r.run(2100);
    let at = outs.iter().position(|o| o.state == State::Armed).unwrap();
    assert_eq!(at, 1999);
    assert_eq!(outs[at].event, Some(Event::Armed(RunMode::FollowPath)));
    // Disarmed by the button: stays disarmed.
    r.press(30);
    assert!(r.run(5000).iter().all(|o| o.state == State::Disarmed));
}

#[test]
fn no_auto_arm_after_a_watchdog_or_software_reset() {
    for cause in [
        ResetCause::Watchdog,
        ResetCause::Software,
        ResetCause::BrownOut,
    ] {
        let mut c = config();
        c.auto_arm_after_steps = Some(100);
        let mut r = Rig::new(c, cause);
        assert!(r.run(1000).iter().all(|o| o.state == State::Disarmed));
    }
}

#[test]
fn using_the_button_cancels_auto_arm() {
    let mut c = config();
    c.auto_arm_after_steps = Some(2000);
    let mut r = Rig::new(c, ResetCause::Pin);
    r.press(1200); // long press: mode switch only
    assert!(r.run(3000).iter().all(|o| o.state == State::Disarmed));
}

#[test]
fn run_timeout_disarms() {
    let mut c = config();
    c.max_armed_steps = Some(1000);
    // The wheels do not turn in this rig: keep the stall check out of the way.
    c.stall.timeout_steps = u32::MAX;
    let mut r = Rig::new(c, ResetCause::PowerOn);
    let mut outs = r.press(30);
    outs.extend(r.run(1100));
    let armed = outs.iter().filter(|o| o.state == State::Armed).count();
    assert_eq!(armed, 1000);
    assert_eq!(
        events(&outs),
        vec![
            Event::Armed(RunMode::FollowPath),
            Event::Disarmed(DisarmReason::Timeout)
        ]
    );
}

#[test]
fn only_the_resets_a_person_causes_allow_auto_arm() {
    assert!(ResetCause::PowerOn.allows_auto_arm() && ResetCause::Pin.allows_auto_arm());
    assert!(!ResetCause::Watchdog.allows_auto_arm());
    assert!(!ResetCause::BrownOut.allows_auto_arm());
    assert!(!ResetCause::Software.allows_auto_arm());
}

#[test]
fn config_validation_names_the_problem() {
    let bad = |f: fn(&mut SupervisorConfig)| {
        let mut c = config();
        f(&mut c);
        Supervisor::new(c, &params(), ResetCause::PowerOn).unwrap_err()
    };
    use SupervisorConfigError as E;
    assert_eq!(bad(|c| c.start_pose.x_m = f32::NAN), E::NonFiniteStartPose);
    assert_eq!(
        bad(|c| c.hold_speeds.left_rad_s = f32::INFINITY),
        E::NonFiniteHoldSpeeds
    );
    assert_eq!(bad(|c| c.debounce_steps = 0), E::BadButtonTiming);
    assert_eq!(bad(|c| c.long_press_steps = 20), E::BadButtonTiming);
    assert_eq!(bad(|c| c.max_consecutive_overruns = 0), E::ZeroOverrunLimit);
    assert_eq!(
        bad(|c| c.background_timeout_steps = 0),
        E::ZeroBackgroundTimeout
    );
    assert_eq!(bad(|c| c.stall.min_volts = 0.0), E::BadStallCheck);
    assert_eq!(bad(|c| c.stall.min_speed_rad_s = -1.0), E::BadStallCheck);
    assert_eq!(bad(|c| c.stall.timeout_steps = 0), E::BadStallCheck);
    assert_eq!(
        bad(|c| c.missed_ticks.max_gap_periods = 1),
        E::BadMissedTickCheck
    );
    assert_eq!(bad(|c| c.geofence_radius_m = Some(-1.0)), E::BadGeofence);
    assert_eq!(
        bad(|c| {
            c.divergence = Some(DivergenceCheck {
                settle_steps: 0,
                bound_m: f32::NAN,
                persist_steps: 1,
            })
        }),
        E::BadDivergenceCheck
    );
    assert_eq!(
        bad(|c| c.heartbeat_timeout_steps = 0),
        E::ZeroHeartbeatTimeout
    );
    assert!(config().validate(&params()).is_ok());
}

impl Rig {
    /// One step with `command` from the link.
    fn command(&mut self, command: Command) -> SupervisorOutput {
        self.command = Some(command);
        self.step()
    }
}

#[test]
fn leaving_armed_brakes_then_coasts() {
    let mut r = rig();
    r.press(30);
    assert_eq!(r.step().bridge, Bridge::Drive);
    let out = r.command(Command::Disarm);
    assert_eq!(out.event, Some(Event::Disarmed(DisarmReason::Link)));
    assert_eq!(out.duty, MotorCommand::STOP);
    // brake_steps = 500 at 1 kHz: the disarming step and 499 more brake, then standby.
    assert_eq!(out.bridge, Bridge::Brake);
    let outs = r.run(600);
    assert!(outs[..499].iter().all(|o| o.bridge == Bridge::Brake));
    assert!(outs[499..].iter().all(|o| o.bridge == Bridge::Coast));
    assert!(outs.iter().all(|o| o.duty == MotorCommand::STOP));
    assert!(!Bridge::Coast.enabled() && Bridge::Brake.enabled() && Bridge::Drive.enabled());
}

#[test]
fn the_link_arms_and_must_keep_sending_heartbeats() {
    let mut r = moving_rig();
    let out = r.command(Command::Arm(ArmRequest::follow_path()));
    assert_eq!(out.command_result, Some(Ok(())));
    assert_eq!(out.event, Some(Event::Armed(RunMode::FollowPath)));
    // Heartbeats every 400 steps keep it armed (timeout 500).
    for _ in 0..5 {
        assert!(r.run(399).iter().all(|o| o.state == State::Armed));
        r.command(Command::Heartbeat);
    }
    // Then silence: disarmed at the 500th step without one.
    let outs = r.run(600);
    let at = outs
        .iter()
        .position(|o| o.state == State::Disarmed)
        .expect("disarmed");
    assert_eq!(at, 499);
    assert_eq!(
        outs[at].event,
        Some(Event::Disarmed(DisarmReason::LinkLost))
    );
}

#[test]
fn the_button_needs_no_heartbeat() {
    let mut r = moving_rig();
    r.moving = false;
    r.press(30);
    r.moving = true;
    assert!(r.run(5000).iter().all(|o| o.state == State::Armed));
}

#[test]
fn the_button_is_a_local_kill_the_link_cannot_override() {
    let mut r = rig();
    r.command(Command::Arm(ArmRequest::follow_path()));
    // A press disarms a robot the link armed.
    r.button = true;
    let outs = r.run(30);
    assert!(outs
        .iter()
        .any(|o| o.event == Some(Event::Disarmed(DisarmReason::Button))));
    // While it is held, the link cannot arm.
    let out = r.command(Command::Arm(ArmRequest::follow_path()));
    assert_eq!(out.command_result, Some(Err(CommandRefusal::ButtonHeld)));
    assert_eq!(out.state, State::Disarmed);
    // Released, the link may arm again.
    r.button = false;
    r.run(50);
    let out = r.command(Command::Arm(ArmRequest::follow_path()));
    assert_eq!(out.command_result, Some(Ok(())));
}

#[test]
fn commands_in_the_wrong_state_are_refused_and_change_nothing() {
    let mut r = rig();
    let out = r.command(Command::ClearFaults);
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Disarmed)))
    );
    r.command(Command::Arm(ArmRequest::follow_path()));
    let out = r.command(Command::Arm(ArmRequest::follow_path()));
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Armed)))
    );
    let out = r.command(Command::BeginPersist);
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Armed)))
    );
    assert_eq!(out.state, State::Armed);
    // Disarm of a disarmed robot is simply done.
    r.command(Command::Disarm);
    assert_eq!(r.command(Command::Disarm).command_result, Some(Ok(())));
    assert!(format!("{}", CommandRefusal::ButtonHeld).contains("button"));
}

#[test]
fn emergency_stop_latches_until_cleared_by_the_link() {
    let mut r = rig();
    r.command(Command::Arm(ArmRequest::follow_path()));
    let out = r.command(Command::EmergencyStop);
    assert_eq!(out.state, State::Faulted);
    assert!(out.faults.has(Fault::EmergencyStop));
    assert_eq!(out.event, Some(Event::Faulted));
    assert_eq!(out.bridge, Bridge::Brake);
    assert!(r.run(100).iter().all(|o| o.state == State::Faulted));
    let out = r.command(Command::ClearFaults);
    assert_eq!(out.event, Some(Event::FaultsCleared));
    assert_eq!(out.state, State::Disarmed);
    assert!(!out.faults.any());
}

#[test]
fn hold_speeds_can_come_with_the_arm_request() {
    let mut r = rig();
    let speeds = WheelSpeeds::new(3.0, -3.0);
    r.command(Command::Arm(ArmRequest {
        mode: RunMode::HoldWheelSpeeds,
        hold_speeds: Some(speeds),
        initial_motion: None,
        max_armed_steps: None,
    }));
    assert_eq!(r.ctl.mode(), Mode::HoldWheelSpeeds(speeds));
}

#[test]
fn the_step_that_arms_drives() {
    let mut r = rig();
    r.moving = true;
    let out = r.command(Command::Arm(ArmRequest::follow_path()));
    assert_eq!(out.state, State::Armed);
    assert_eq!(out.event, Some(Event::Armed(RunMode::FollowPath)));
    assert_eq!(out.bridge, Bridge::Drive);
    assert_eq!(r.ctl.mode(), Mode::FollowPath);
    assert_eq!(out.duty, out.controller_duty, "its duties reach the motors");
}

#[test]
fn arming_ended_by_a_disarm_or_a_fault_in_the_same_step_leaves_the_controller_idle() {
    let mut r = rig();
    r.command(Command::Arm(ArmRequest::follow_path()));
    assert_eq!(r.ctl.mode(), Mode::FollowPath);
    r.command(Command::Disarm);
    assert_eq!(r.ctl.mode(), Mode::Idle);
    // Armed, and faulted in the same step (an encoder jump): idle, motors stopped.
    r.step();
    r.command = Some(Command::Arm(ArmRequest::follow_path()));
    let out = r.step_with(TickDeltas {
        left: 1_000_000,
        right: 0,
    });
    assert_eq!(out.state, State::Faulted);
    assert_eq!(out.duty, MotorCommand::STOP);
    r.step();
    assert_eq!(r.ctl.mode(), Mode::Idle);
}

#[test]
fn arming_in_motion_seeds_the_speed_estimate() {
    let mut r = rig();
    r.moving = true;
    let out = r.command(Command::Arm(ArmRequest {
        mode: RunMode::FollowPath,
        hold_speeds: None,
        initial_motion: Some(BodyVelocity::new(0.1625, 0.0)),
        max_armed_steps: None,
    }));
    assert_eq!(out.state, State::Armed);
    // 0.1625 m/s on 32.5 mm wheels is 5 rad/s: the estimate starts there, not at 0.
    let w = r.ctl.telemetry().wheel_speed;
    assert!((w.left_rad_s - 5.0).abs() < 0.3, "{w:?}");
}

#[test]
fn late_steps_are_counted_and_too_many_fault() {
    let mut r = rig();
    r.press(30);
    r.periods = NonZeroU32::new(3).unwrap();
    let out = r.step();
    assert_eq!(out.missed_ticks_total, 2);
    assert_eq!(out.state, State::Armed);
    // 20 missed in a second are tolerated, 21 are not: 2 per late step, so the 11th.
    r.periods = NonZeroU32::new(3).unwrap();
    let outs: Vec<_> = (0..10).map(|_| r.step()).collect();
    assert!(outs[..9].iter().all(|o| o.state == State::Armed));
    assert_eq!(outs[9].state, State::Faulted);
    assert!(outs[9].faults.has(Fault::MissedTicks));
}

#[test]
fn a_long_gap_faults_at_once() {
    let mut r = rig();
    r.periods = NonZeroU32::new(10).unwrap();
    let out = r.step();
    assert!(out.faults.has(Fault::MissedTicks));
}

#[test]
fn missed_ticks_while_persisting_are_not_a_fault() {
    let mut r = rig();
    let out = r.command(Command::BeginPersist);
    assert_eq!(out.state, State::Persisting);
    assert_eq!(out.event, Some(Event::PersistStarted));
    assert_eq!(out.bridge, Bridge::Coast);
    // A 1.2 s flash erase: one step that covered 1200 periods.
    r.periods = NonZeroU32::new(1200).unwrap();
    let out = r.step();
    assert!(!out.faults.any());
    assert_eq!(out.missed_ticks_total, 1199);
    r.periods = NonZeroU32::MIN;
    let out = r.command(Command::EndPersist);
    assert_eq!(out.state, State::Disarmed);
    assert_eq!(out.event, Some(Event::PersistEnded));
    // Arming is refused while persisting.
    r.command(Command::BeginPersist);
    let out = r.command(Command::Arm(ArmRequest::follow_path()));
    assert_eq!(
        out.command_result,
        Some(Err(CommandRefusal::WrongState(State::Persisting)))
    );
}

#[test]
fn the_supervisors_own_flags_stay_latched_when_the_controller_clears_its_own() {
    let mut r = rig();
    r.press(30);
    r.step_with(TickDeltas {
        left: 10_000,
        right: 0,
    });
    assert!(r.sup.faults().has(Fault::EncoderJump));
    // Something clears the controller's flags behind the supervisor's back: the
    // supervisor's latched copy must not follow.
    r.ctl.clear_faults();
    let out = r.step();
    assert!(out.faults.has(Fault::EncoderJump));
    assert_eq!(out.state, State::Faulted);
}

#[test]
fn a_low_battery_warns_then_faults() {
    let mut r = rig();
    r.press(30);
    // The wheels turn: this is about the battery, not a stall.
    r.moving = true;
    r.supply_v = 4.8;
    let outs = r.run(400);
    // Warning after the 200 ms debounce (and the 20 ms filter's settling), once.
    assert_eq!(
        outs.iter()
            .filter(|o| o.event == Some(Event::BatteryLow))
            .count(),
        1
    );
    assert!(outs.last().unwrap().battery_low);
    assert_eq!(outs.last().unwrap().state, State::Armed);
    r.supply_v = 4.4;
    let outs = r.run(400);
    let last = outs.last().unwrap();
    assert!(last.faults.has(Fault::SupplyLow));
    assert_eq!(last.state, State::Faulted);
}

#[test]
fn a_supply_above_the_bridge_maximum_faults() {
    // A DRV8833 (10.8 V maximum) on a 3S pack.
    let mut ctl = controller();
    let mut robot = *ctl.params().config();
    robot.drive.max_supply_v = 10.8;
    robot.drive.min_supply_v = 2.7;
    let params = Params::new(robot).unwrap();
    ctl = Controller::new(params, ctl.reference().clone(), ctl.law(), Pose::default());
    let mut sup = Supervisor::new(config(), &params, ResetCause::PowerOn).unwrap();
    let mut out = sup.step(&mut ctl, Inputs::at_supply(12.6));
    for _ in 0..300 {
        out = sup.step(&mut ctl, Inputs::at_supply(12.6));
    }
    assert!(out.faults.has(Fault::SupplyHigh));
    assert_eq!(out.state, State::Faulted);
}

#[test]
fn losing_control_faults_after_the_settling_window() {
    // The controller believes it drives the line while the encoders report the wheels
    // standing still (e.g. a path the motors cannot follow): the error grows past the
    // bound and stays there.
    let mut c = config();
    c.divergence = Some(DivergenceCheck {
        settle_steps: 1000,
        bound_m: 0.3,
        persist_steps: 1000,
    });
    c.stall.timeout_steps = u32::MAX;
    let mut r = Rig::new(c, ResetCause::PowerOn);
    r.command(Command::Arm(ArmRequest::follow_path()));
    r.command = None;
    let mut faulted_at = None;
    for k in 0..6000u32 {
        r.command = Some(Command::Heartbeat);
        let out = r.step();
        if out.faults.has(Fault::Divergence) {
            faulted_at = Some(k);
            break;
        }
    }
    // The robot stands 0.2 m beside the line and the reference leaves it at 0.2 m/s: the
    // error passes 0.3 m at √(0.3² − 0.2²)/0.2 = 1.118 s (after the 1 s settling window),
    // then 1 s of persistence: the fault comes at 2.118 s.
    let at = faulted_at.expect("divergence detected");
    assert!((2110..2130).contains(&at), "{at}");
}

#[test]
fn leaving_the_geofence_faults() {
    let mut c = config();
    c.geofence_radius_m = Some(0.5);
    let mut r = Rig::new(c, ResetCause::PowerOn);
    r.press(30);
    r.ctl.set_pose(Pose::new(0.6, -0.2, 0.0));
    let out = r.step();
    assert!(out.faults.has(Fault::Geofence));
    assert_eq!(out.state, State::Faulted);
}

#[test]
fn new_tune_settings_only_while_disarmed_and_only_valid_ones() {
    let mut r = rig();
    let mut slower = *r.sup.tune_config();
    slower.max_hold_s = 2.0;
    assert_eq!(r.sup.set_tune_config(slower, &params()), Ok(()));
    assert_eq!(r.sup.tune_config().max_hold_s, 2.0);
    let mut bad = slower;
    bad.experiment_volts_v = -1.0;
    assert!(matches!(
        r.sup.set_tune_config(bad, &params()),
        Err(SupervisorSetError::InvalidTune(_))
    ));
    assert_eq!(
        r.sup.tune_config().max_hold_s,
        2.0,
        "a refused setting changes nothing"
    );
    r.press(30);
    let mut other = slower;
    other.max_hold_s = 3.0;
    assert_eq!(
        r.sup.set_tune_config(other, &params()),
        Err(SupervisorSetError::NotDisarmed(State::Armed))
    );
    assert_eq!(r.sup.tune_config().max_hold_s, 2.0);
}

#[test]
fn tune_settings_the_new_robot_refuses_give_way_to_its_defaults() {
    // The tune is set to ask 5 V of the 6 V motor; a 4 V motor refuses that.
    let mut r = rig();
    let mut strong = *r.sup.tune_config();
    strong.experiment_volts_v = 5.0;
    assert_eq!(r.sup.set_tune_config(strong, &params()), Ok(()));
    let mut robot = *params().config();
    robot.motor.rated_voltage_v = 4.0;
    let weaker = Params::new(robot).unwrap();
    assert!(r.sup.tune_config().validate(&weaker).is_err());
    assert_eq!(r.sup.set_config(config(), &weaker), Ok(()));
    assert_eq!(r.sup.tune_config().validate(&weaker), Ok(()));
    assert_eq!(*r.sup.tune_config(), TuneConfig::for_robot(weaker.config()));
    // Settings the new robot accepts are kept.
    assert_eq!(r.sup.set_tune_config(strong, &params()), Ok(()));
    assert_eq!(r.sup.set_config(config(), &params()), Ok(()));
    assert_eq!(r.sup.tune_config().experiment_volts_v, 5.0);
}

#[test]
fn new_settings_only_while_disarmed() {
    let mut r = rig();
    let mut c = config();
    c.brake_steps = 10;
    assert_eq!(r.sup.set_config(c, &params()), Ok(()));
    assert_eq!(r.sup.config().brake_steps, 10);
    r.press(30);
    assert_eq!(
        r.sup.set_config(config(), &params()),
        Err(SupervisorSetError::NotDisarmed(State::Armed))
    );
    r.press(30);
    let mut bad = config();
    bad.debounce_steps = 0;
    assert_eq!(
        r.sup.set_config(bad, &params()),
        Err(SupervisorSetError::Invalid(
            SupervisorConfigError::BadButtonTiming
        ))
    );
}

#[test]
fn a_local_arm_needs_no_heartbeat_and_only_from_disarmed() {
    let mut r = moving_rig();
    let event = r.sup.arm_locally(&mut r.ctl, ArmRequest::follow_path());
    assert_eq!(event, Ok(Event::Armed(RunMode::FollowPath)));
    assert!(r.run(3000).iter().all(|o| o.state == State::Armed));
    assert_eq!(
        r.sup.arm_locally(&mut r.ctl, ArmRequest::follow_path()),
        Err(CommandRefusal::WrongState(State::Armed))
    );
    r.command(Command::Disarm);
    r.button = true;
    r.run(30);
    assert_eq!(
        r.sup.arm_locally(&mut r.ctl, ArmRequest::follow_path()),
        Err(CommandRefusal::ButtonHeld)
    );
}

#[test]
fn hold_speeds_with_the_request_are_taken_only_when_both_are_numbers() {
    let hold = |left: f32, right: f32| ArmRequest {
        mode: RunMode::HoldWheelSpeeds,
        hold_speeds: Some(WheelSpeeds::new(left, right)),
        initial_motion: None,
        max_armed_steps: None,
    };
    for (left, right) in [(f32::NAN, 3.0), (3.0, f32::INFINITY)] {
        let mut r = rig();
        assert!(r.sup.arm_locally(&mut r.ctl, hold(left, right)).is_ok());
        assert_eq!(r.sup.config().hold_speeds, HOLD, "{left} {right}");
    }
    let mut r = rig();
    assert!(r.sup.arm_locally(&mut r.ctl, hold(4.0, 3.0)).is_ok());
    assert_eq!(r.sup.config().hold_speeds, WheelSpeeds::new(4.0, 3.0));
}

#[test]
fn a_loop_stuck_at_its_limits_faults() {
    // The wheels do not turn while the line-following loops push: saturated within the
    // first tens of steps (as soon as the integral has pushed the voltage to the current
    // limit), the fault comes once more than half of the 1 s window has passed so.
    let mut c = SupervisorConfig::at_rate(1000, START, HOLD);
    c.stall.timeout_steps = u32::MAX;
    let mut r = Rig::new(c, ResetCause::PowerOn);
    r.sup
        .arm_locally(&mut r.ctl, ArmRequest::follow_path())
        .unwrap();
    let outs = r.run(1000);
    let at = outs
        .iter()
        .position(|o| o.faults.has(Fault::Saturated))
        .expect("saturation detected");
    assert!((500..=550).contains(&at), "{at}");
    assert_eq!(outs[at].state, State::Faulted);
}

#[test]
fn a_refused_setting_says_why_and_keeps_its_cause() {
    use core::error::Error as _;
    let armed = SupervisorSetError::NotDisarmed(State::Armed);
    assert!(armed.to_string().contains("Armed") && armed.source().is_none());
    let invalid = SupervisorSetError::Invalid(SupervisorConfigError::NonFiniteStartPose);
    assert_eq!(
        invalid.source().map(ToString::to_string),
        Some(SupervisorConfigError::NonFiniteStartPose.to_string())
    );
    assert_ne!(invalid.to_string(), armed.to_string());
}

mod gyro;
mod motor_test;
mod rearm;
mod velocity;
