//! The controller on a straight line: modes, the outer loop owned and lent, late steps,
//! the set-point ramp, the supply's effect on the caps, faults and bounded duties.

use super::*;
use crate::gyro::HeadingSource;
use crate::kinematics::Point;
use crate::params::RobotConfig;
use crate::path::Path;
use crate::reference::ReferenceMode;
use proptest::prelude::*;

/// The reference robot with the tracking law on a line along +x of `length_m` (m),
/// reference at 0.2 m/s, believing it starts at the origin. Shared with the
/// supervisor's tests.
pub(crate) fn on_a_line(length_m: f32) -> Controller {
    on_a_line_from(Point::new(0.0, 0.0), length_m)
}

/// As [`on_a_line`], with the line and the robot's belief starting at `start` (world
/// frame, m) instead of the origin.
pub(crate) fn on_a_line_from(start: Point, length_m: f32) -> Controller {
    let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
    let path = Path::line(start, 0.0, length_m).unwrap();
    let reference = Reference::new(
        path,
        0.2,
        ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        },
    )
    .unwrap();
    let pose = Pose::new(start.x_m, start.y_m, 0.0);
    Controller::new(params, reference, LawKind::Tracking, pose)
}

fn controller() -> Controller {
    on_a_line(5.0)
}

/// The supply the tests run on, V.
const SUPPLY_V: f32 = 6.0;

/// One on-time step with `ticks` on the test supply.
fn step<S: OuterLoopHolder>(c: &mut Controller<S>, ticks: TickDeltas) -> MotorCommand {
    c.step(StepInput::on_time(ticks, SUPPLY_V))
}

fn ticks(left: i32, right: i32) -> TickDeltas {
    TickDeltas { left, right }
}

/// A controller that has driven for a while, then is rebuilt in place, is the one
/// `Controller::new` builds (every field, as `Debug` shows them), but for what is kept:
/// its pose (and, with new parameters, where its reference is in its run).
#[test]
fn rebuilding_in_place_equals_building_anew() {
    let mut params_config = RobotConfig::REFERENCE_ROBOT;
    params_config.wheel_radius_left_m *= 1.01;
    params_config.speed_window_steps = 12;
    let other_params = Params::new(params_config).unwrap();
    let other_path = Path::line(Point::new(1.0, 2.0), 0.5, 3.0).unwrap();
    let mut other_reference = Reference::new(
        other_path,
        0.3,
        ReferenceMode::PathFollowing { lookahead_m: 0.1 },
    )
    .unwrap();
    let start = Pose::new(0.5, -0.25, 1.0);
    let _ = other_reference.sample(0, NonZeroU32::MIN, &start);
    let driven = || {
        let mut c = controller();
        c.set_mode(Mode::FollowPath);
        for k in 0..40 {
            step(&mut c, ticks(k % 3, 2));
        }
        c
    };

    let mut rebuilt = driven();
    let reference = rebuilt.reference().clone();
    let pose = rebuilt.pose();
    let owed = rebuilt.schedule.since_sample;
    rebuilt
        .rebuild(&other_params, LawKind::Kanayama)
        .expect("owned outer loop");
    let mut fresh = Controller::new(other_params, reference, LawKind::Kanayama, pose);
    // The reference goes on where it was: resumed, owed the periods since its sample.
    fresh.reference_afresh = false;
    fresh.schedule.since_sample = owed;
    assert!(owed > 0, "the test drives past a steering update");
    assert_eq!(format!("{rebuilt:?}"), format!("{fresh:?}"));

    let mut followed = driven();
    let (odometry, fusion) = (followed.odometry, followed.fusion);
    followed
        .follow(&other_reference, LawKind::Kanayama)
        .expect("owned outer loop");
    let mut fresh = Controller::new(
        *controller().params(),
        other_reference.clone(),
        LawKind::Kanayama,
        start,
    );
    // A new path does not move the robot: its odometry and heading fusion are the
    // driven one's, whole.
    fresh.odometry = odometry;
    fresh.fusion = fusion;
    fresh.telemetry.pose = fresh.odometry.pose();
    assert_eq!(format!("{followed:?}"), format!("{fresh:?}"));
    assert_ne!(format!("{followed:?}"), format!("{:?}", driven()));
}

/// New parameters bring their gyro configuration (here a new heading source) into the
/// running fusion, and the bias it learned at rest, which is the sensor's, stays.
#[test]
fn a_rebuild_takes_the_new_gyro_configuration_and_keeps_the_sensors_bias() {
    let mut c = controller();
    for _ in 0..200 {
        c.step(StepInput {
            gyro: Some(crate::gyro::GyroSample {
                yaw_rate_radps: 0.01,
                age_periods: 0,
            }),
            still: true,
            ..StepInput::on_time(ticks(0, 0), SUPPLY_V)
        });
    }
    let bias = c.fusion.report().bias_radps;
    assert!((bias - 0.01).abs() < 1e-4, "learned at rest: {bias}");
    assert_eq!(c.fusion.config().heading_source, HeadingSource::Odometry);
    let mut config = *c.params().config();
    config.gyro = config.gyro.with_heading(HeadingSource::Fused);
    config.gyro.scale = 1.01;
    c.rebuild(&Params::new(config).unwrap(), LawKind::Tracking)
        .expect("owned outer loop");
    assert_eq!(*c.fusion.config(), config.gyro);
    // The same sensor bias, in the robot's frame of the new scale.
    assert_eq!(c.fusion.report().bias_radps, bias * 1.01);
}

#[test]
fn idle_commands_nothing() {
    let mut c = controller();
    for _ in 0..100 {
        assert_eq!(step(&mut c, ticks(1, 1)), MotorCommand::STOP);
    }
    // Odometry still runs while idle.
    assert!(c.pose().x_m > 0.0);
}

#[test]
fn follow_path_drives_forward() {
    let mut c = controller();
    c.set_mode(Mode::FollowPath);
    // The first step hands the law its job and holds the wheels where they are (at
    // rest); the next one applies the law's command.
    let duty = step(&mut c, ticks(0, 0));
    assert!(!c.telemetry().steering_updated);
    assert_eq!(c.telemetry().wheel_setpoint, WheelSpeeds::default());
    assert_eq!(duty, MotorCommand::STOP);
    let duty = step(&mut c, ticks(0, 0));
    assert!(c.telemetry().steering_updated);
    assert!(duty.left > 0.0 && duty.right > 0.0);
    assert!(!c.faults().any());
    // The steering law runs every `steering_divider` (10) steps, the PIDs every step.
    let pattern: Vec<bool> = (1..=20)
        .map(|_| {
            step(&mut c, ticks(0, 0));
            c.telemetry().steering_updated
        })
        .collect();
    let expected: Vec<bool> = (1..=20).map(|k| k % 10 == 0).collect();
    assert_eq!(pattern, expected);
}

#[test]
fn the_steering_outcome_of_a_step_is_applied_at_the_next() {
    // The law's job carries this step's pose; its outcome, applied one step later, is
    // exactly what the outer loop computes from that job.
    let mut c = on_a_line(5.0);
    c.set_pose(Pose::new(0.0, 0.05, 0.1));
    c.set_mode(Mode::FollowPath);
    let mut outer = OuterLoop::new(c.params(), c.reference().clone(), c.law());
    step(&mut c, ticks(3, 5));
    let job = OuterLoopJob {
        pose: c.pose(),
        heading_sin_cos: c.odometry.heading_sin_cos(),
        elapsed_periods: 0,
        // 0.85 · 6 V → 30.4 rad/s → 0.987 m/s (see the weak-supply test).
        rim_speed_cap_m_s: 0.987_420_4,
        reference_restart: ReferenceRestart::Afresh,
        restart_limiter_from: Some(BodyVelocity::new(0.0, 0.0)),
        epoch: c.epoch,
    };
    assert_eq!(c.steering_job(), job);
    outer.run(&job);
    let expected = *outer.outcome();
    assert_eq!(expected.epoch, job.epoch);
    let setpoint_before = c.telemetry().wheel_setpoint;
    step(&mut c, ticks(4, 4));
    let t = c.telemetry();
    assert!(t.steering_updated);
    assert_eq!(t.command, expected.command);
    assert_eq!(t.error, expected.error);
    assert_eq!(t.reference, expected.reference);
    // The ramp starts at this step, one tenth of the way to the command's wheels.
    let target = c.params().geometry().inverse(expected.command);
    let tenth =
        setpoint_before.left_rad_s + (target.left_rad_s - setpoint_before.left_rad_s) / 10.0;
    assert!((t.wheel_setpoint.left_rad_s - tenth).abs() < 1e-5, "{t:?}");
}

/// A holder that lends its outer loop, and runs what it lent when the test says so (as
/// the firmware's lower-priority task does).
#[derive(Clone, Debug)]
struct Lending {
    home: Option<OuterLoop>,
    /// Lent: the outer loop, its job, and whether it ran.
    away: Option<(OuterLoop, OuterLoopJob, bool)>,
}

impl Lending {
    /// Runs the lent job.
    fn run_away(&mut self) {
        let (steering, job, ran) = self.away.as_mut().expect("lent");
        steering.run(job);
        *ran = true;
    }
}

impl OuterLoopHolder for Lending {
    fn held(&self) -> Option<&OuterLoop> {
        self.home.as_ref()
    }

    fn held_mut(&mut self) -> Option<&mut OuterLoop> {
        self.home.as_mut()
    }

    fn runs_jobs(&self) -> bool {
        false
    }

    fn lend(&mut self, job: &OuterLoopJob) -> bool {
        let Some(steering) = self.home.take() else {
            return false;
        };
        self.away = Some((steering, *job, false));
        true
    }

    fn collect(&mut self) -> bool {
        match self.away.take() {
            Some((steering, _, true)) => {
                self.home = Some(steering);
                true
            }
            still_away => {
                self.away = still_away;
                false
            }
        }
    }
}

/// `owned` as it was built, with a lending holder.
fn lending(owned: &Controller) -> Controller<Lending> {
    let steering = OuterLoop::new(owned.params(), owned.reference().clone(), owned.law());
    let holder = Lending {
        home: Some(steering),
        away: None,
    };
    Controller::with_holder(*owned.params(), holder, Pose::default())
}

#[test]
fn a_lent_outer_loop_does_what_an_owned_one_does() {
    let mut owned = on_a_line(5.0);
    let mut lent = lending(&owned);
    owned.set_pose(Pose::new(0.0, 0.05, 0.1));
    lent.set_pose(Pose::new(0.0, 0.05, 0.1));
    owned.set_mode(Mode::FollowPath);
    lent.set_mode(Mode::FollowPath);
    let mut jobs = 0;
    for k in 0..300 {
        assert!(lent.collect_steering(), "step {k}: the outer loop is back");
        assert_eq!(lent.steering().map(OuterLoop::law), Some(owned.law()));
        if k == 151 {
            // An external fix between a due step (150) and the next: the job keeps
            // the pose it was due with, as the lent one did.
            owned.set_pose(Pose::new(0.3, 0.04, 0.05));
            lent.set_pose(Pose::new(0.3, 0.04, 0.05));
        }
        let t = ticks(2 + k % 3, 3);
        let duty = step(&mut owned, t);
        assert_eq!(lent.step(StepInput::on_time(t, SUPPLY_V)), duty, "step {k}");
        assert_eq!(lent.telemetry(), owned.telemetry(), "step {k}");
        // The lending holder runs no job itself: each waits to be lent.
        if lent.lend_steering() {
            jobs += 1;
            // Away: what needs the outer loop waits.
            let params = *lent.params();
            assert!(!lent.collect_steering());
            assert!(lent.steering().is_none());
            assert_eq!(lent.set_law(LawKind::Paper), Err(OuterLoopAway));
            assert_eq!(lent.rebuild(&params, LawKind::Paper), Err(OuterLoopAway));
            lent.holder_mut().run_away();
        }
        assert!(!lent.lend_steering(), "one job per due step");
    }
    // One job every 10 steps.
    assert_eq!(jobs, 30);
    assert!(owned.telemetry().pose.x_m > 0.1);
}

#[test]
fn an_owned_outer_loop_is_never_lent_and_never_collected() {
    // Lending and collecting are for holders that lend: on an owned outer loop they do
    // nothing, and the controller runs its own jobs.
    let mut plain = on_a_line(5.0);
    let mut asked = on_a_line(5.0);
    plain.set_mode(Mode::FollowPath);
    asked.set_mode(Mode::FollowPath);
    for k in 0..50 {
        assert!(asked.collect_steering(), "held");
        if k == 11 {
            // The job due at step 10 runs aside here; its outcome is applied once.
            plain.set_pose(Pose::new(0.02, 0.01, 0.0));
            asked.set_pose(Pose::new(0.02, 0.01, 0.0));
        }
        step(&mut plain, ticks(3, 3));
        step(&mut asked, ticks(3, 3));
        assert!(!asked.lend_steering(), "step {k}");
        assert_eq!(asked.telemetry(), plain.telemetry(), "step {k}");
    }
    assert!(plain.telemetry().steering_updated || plain.telemetry().command.v_m_s > 0.0);
}

#[test]
fn an_outcome_from_before_a_restart_is_ignored() {
    let mut c = lending(&controller());
    c.set_mode(Mode::FollowPath);
    step(&mut c, ticks(0, 0));
    assert!(c.lend_steering());
    c.holder_mut().run_away();
    // Disarmed and armed again while the job ran.
    c.set_mode(Mode::Idle);
    c.set_mode(Mode::FollowPath);
    assert!(c.collect_steering());
    step(&mut c, ticks(0, 0));
    assert!(!c.telemetry().steering_updated);
    // The new run's own first job is lent, and its outcome applied.
    assert!(c.lend_steering());
    c.holder_mut().run_away();
    assert!(c.collect_steering());
    step(&mut c, ticks(0, 0));
    assert!(c.telemetry().steering_updated);
}

#[test]
fn a_restart_drops_a_steering_outcome_not_yet_applied() {
    // Following, then idle and following again before the outcome of the first step
    // was applied: the new run starts from its own first job, not the stale command.
    let mut c = controller();
    c.set_mode(Mode::FollowPath);
    step(&mut c, ticks(0, 0));
    c.set_mode(Mode::Idle);
    c.set_mode(Mode::FollowPath);
    step(&mut c, ticks(0, 0));
    assert!(!c.telemetry().steering_updated);
    assert_eq!(c.telemetry().wheel_setpoint, WheelSpeeds::default());
    step(&mut c, ticks(0, 0));
    assert!(c.telemetry().steering_updated);
}

#[test]
fn entering_follow_path_restarts_the_reference_and_the_steering_phase() {
    // Idle for 7 steps, then following: the law runs on the first step (its outcome
    // applied on the second) and the reference starts at its beginning, as in a
    // controller that followed at once.
    let mut fresh = controller();
    fresh.set_mode(Mode::FollowPath);
    step(&mut fresh, ticks(0, 0));
    step(&mut fresh, ticks(0, 0));
    let mut late = controller();
    for _ in 0..7 {
        step(&mut late, ticks(0, 0));
    }
    late.set_mode(Mode::FollowPath);
    step(&mut late, ticks(0, 0));
    step(&mut late, ticks(0, 0));
    assert!(late.telemetry().steering_updated);
    assert_eq!(
        late.telemetry().reference.progress_m,
        fresh.telemetry().reference.progress_m
    );
}

#[test]
fn following_again_after_a_pause_resumes_the_reference_and_a_pose_command_restarts_it() {
    // 502 steps of following (the first adds no time: 501 periods), a pause of 300
    // steps, and following again: the time-indexed reference's clock paused and goes on
    // from 501 periods, 0.2 m/s × 0.501 s along the line, not from its start.
    let mut c = controller();
    c.set_mode(Mode::FollowPath);
    for _ in 0..502 {
        step(&mut c, ticks(0, 0));
    }
    c.set_mode(Mode::Idle);
    for _ in 0..300 {
        step(&mut c, ticks(0, 0));
    }
    c.set_mode(Mode::FollowPath);
    assert_eq!(c.steering_job().reference_restart, ReferenceRestart::Resume);
    step(&mut c, ticks(0, 0));
    step(&mut c, ticks(0, 0));
    assert!(c.telemetry().steering_updated);
    let resumed = c.telemetry().reference.progress_m;
    assert!((resumed - 0.2 * 0.501).abs() < 1e-6, "{resumed}");
    // Disarmed again and told where it is: the next run starts the reference afresh.
    c.set_mode(Mode::Idle);
    c.set_pose(Pose::new(0.0, 0.0, 0.0));
    c.set_mode(Mode::FollowPath);
    step(&mut c, ticks(0, 0));
    step(&mut c, ticks(0, 0));
    assert!(c.telemetry().steering_updated);
    assert_eq!(c.telemetry().reference.progress_m, 0.0);
}

#[test]
fn entering_twice_before_a_job_keeps_the_stronger_restart() {
    // A pose command, following entered and left before any step, then entered again:
    // the job still starts the reference afresh.
    let mut c = controller();
    c.set_mode(Mode::FollowPath);
    for _ in 0..300 {
        step(&mut c, ticks(0, 0));
    }
    c.set_mode(Mode::Idle);
    c.set_pose(Pose::new(0.0, 0.0, 0.0));
    c.set_mode(Mode::FollowPath);
    c.set_mode(Mode::Idle);
    c.set_mode(Mode::FollowPath);
    assert_eq!(c.steering_job().reference_restart, ReferenceRestart::Afresh);
    step(&mut c, ticks(0, 0));
    step(&mut c, ticks(0, 0));
    assert_eq!(c.telemetry().reference.progress_m, 0.0);
}

#[test]
fn a_new_path_or_new_parameters_keep_the_pose() {
    // Odometry counts while idle; neither an installed path nor new parameters move it.
    let mut c = controller();
    for _ in 0..50 {
        step(&mut c, ticks(3, 4));
    }
    let pose = c.pose();
    assert!(pose.x_m > 0.0 && pose.theta_rad != 0.0);
    let reference = c.reference().clone();
    c.follow(&reference, LawKind::Tracking).expect("owned");
    assert_eq!(c.pose(), pose);
    let params = *c.params();
    c.rebuild(&params, LawKind::Tracking).expect("owned");
    let kept = c.pose();
    assert_eq!((kept.x_m, kept.y_m), (pose.x_m, pose.y_m));
    assert!((kept.theta_rad - pose.theta_rad).abs() < 1e-6);
}

#[test]
fn the_wheel_pid_parts_show_the_drive_pushing_forward() {
    // Following from rest: both set-points are ahead of the measured 0 rad/s, so each
    // wheel's proportional and feed-forward parts push forward.
    let mut c = controller();
    c.set_mode(Mode::FollowPath);
    step(&mut c, ticks(0, 0));
    step(&mut c, ticks(0, 0));
    for part in c.wheel_pid_parts() {
        assert!(part.p > 0.0, "{part:?}");
        assert!(part.ff > 0.0, "{part:?}");
    }
}

#[test]
fn the_set_point_ramp_is_linear_per_wheel_and_stops_at_its_target() {
    let mut ramp = SetpointRamp::default();
    let mut sp = WheelSpeeds::new(2.0, -4.0);
    ramp.start(sp, WheelSpeeds::new(4.0, 6.0), NonZeroU32::new(10).unwrap());
    ramp.advance(5, &mut sp);
    assert!((sp.left_rad_s - 3.0).abs() < 1e-5, "{sp:?}");
    assert!((sp.right_rad_s - 1.0).abs() < 1e-5, "{sp:?}");
    ramp.advance(5, &mut sp);
    assert_eq!(sp, WheelSpeeds::new(4.0, 6.0));
    // It stays there until the next start.
    ramp.advance(1, &mut sp);
    assert_eq!(sp, WheelSpeeds::new(4.0, 6.0));
    // Steps of 2 periods count down 10 periods: after three, 6/10 of the way.
    let mut sp = WheelSpeeds::new(2.0, -4.0);
    ramp.start(sp, WheelSpeeds::new(4.0, 6.0), NonZeroU32::new(10).unwrap());
    for _ in 0..3 {
        ramp.advance(2, &mut sp);
    }
    assert!((sp.left_rad_s - 3.2).abs() < 1e-5, "{sp:?}");
}

#[test]
fn a_delta_of_exactly_the_plausible_maximum_is_no_encoder_jump() {
    // The limit is inclusive, on each wheel.
    let limit = Params::new(RobotConfig::REFERENCE_ROBOT)
        .unwrap()
        .max_ticks_per_step();
    for (left, right) in [(limit, 0), (0, limit), (-limit, -limit)] {
        let mut c = controller();
        step(&mut c, ticks(left, right));
        assert!(!c.faults().any(), "{left} {right}");
    }
    for (left, right) in [(limit + 1, 0), (0, -limit - 1)] {
        let mut c = controller();
        step(&mut c, ticks(left, right));
        assert!(c.faults().encoder_jump, "{left} {right}");
    }
}

#[test]
fn a_late_step_moves_the_set_point_ramp_by_the_periods_it_covered() {
    // After a steering step, three on-time steps and one step covering three periods
    // leave the wheel set-points at the same point of the ramp.
    let mut on_time = controller();
    let mut late = controller();
    for c in [&mut on_time, &mut late] {
        c.set_mode(Mode::FollowPath);
        for _ in 0..25 {
            step(c, ticks(1, 1));
        }
    }
    let before = on_time.telemetry().wheel_setpoint;
    for _ in 0..3 {
        step(&mut on_time, ticks(1, 1));
    }
    late.step(StepInput {
        ticks: ticks(3, 3),
        periods: NonZeroU32::new(3).unwrap(),
        supply_v: SUPPLY_V,
        gyro: None,
        still: false,
    });
    let (a, b) = (
        on_time.telemetry().wheel_setpoint,
        late.telemetry().wheel_setpoint,
    );
    assert!(
        (a.left_rad_s - before.left_rad_s).abs() > 1e-3,
        "the ramp moves"
    );
    assert!((a.left_rad_s - b.left_rad_s).abs() < 1e-5, "{a:?} {b:?}");
    assert!((a.right_rad_s - b.right_rad_s).abs() < 1e-5, "{a:?} {b:?}");
}

#[test]
fn switching_from_holding_to_following_continues_from_the_measured_speed() {
    // Wheels held at 8.73 rad/s (2 ticks per 1 ms step), then path following with the
    // reference at 0.2 m/s: the acceleration limit starts from the measured 0.28 m/s,
    // so the first set-points stay near the measured speed instead of restarting
    // from 0.
    let mut c = controller();
    let held = 2.0 * core::f32::consts::TAU / 1440.0 * 1000.0;
    c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(held, held)));
    for _ in 0..300 {
        step(&mut c, ticks(2, 2));
    }
    c.set_mode(Mode::FollowPath);
    step(&mut c, ticks(2, 2));
    let setpoint = c.telemetry().wheel_setpoint;
    assert!(setpoint.left_rad_s > 0.9 * held, "{setpoint:?}");
    assert!(setpoint.right_rad_s > 0.9 * held, "{setpoint:?}");
}

#[test]
fn a_late_step_moves_the_reference_by_the_time_that_passed() {
    // Two controllers, one stepped 21 times on time (steps at 0…20 ms), the other 10
    // times on time (0…9 ms) and then once covering 11 periods (at 20 ms): at that
    // steering step both references must be at 20 ms · 0.2 m/s = 4 mm. The outcome
    // shows one step later.
    let mut on_time = controller();
    let mut late = controller();
    on_time.set_mode(Mode::FollowPath);
    late.set_mode(Mode::FollowPath);
    for _ in 0..20 {
        step(&mut on_time, ticks(0, 0));
    }
    step(&mut on_time, ticks(0, 0));
    for _ in 0..10 {
        step(&mut late, ticks(0, 0));
    }
    late.step(StepInput {
        ticks: ticks(0, 0),
        periods: NonZeroU32::new(11).unwrap(),
        supply_v: SUPPLY_V,
        gyro: None,
        still: false,
    });
    assert_eq!(late.telemetry().periods, 11);
    step(&mut on_time, ticks(0, 0));
    step(&mut late, ticks(0, 0));
    assert!(on_time.telemetry().steering_updated);
    assert!(late.telemetry().steering_updated);
    let (a, b) = (
        on_time.telemetry().reference.progress_m,
        late.telemetry().reference.progress_m,
    );
    assert!(
        (a - 0.004).abs() < 1e-6 && (b - 0.004).abs() < 1e-6,
        "{a} {b}"
    );
}

#[test]
fn a_late_step_is_not_an_encoder_jump_for_the_time_it_covered() {
    // 45 ticks per period is the limit; 80 ticks over 2 periods is 40 per period.
    let mut c = controller();
    c.step(StepInput {
        ticks: ticks(80, 80),
        periods: NonZeroU32::new(2).unwrap(),
        supply_v: SUPPLY_V,
        gyro: None,
        still: false,
    });
    assert!(!c.faults().any());
    step(&mut c, ticks(80, 0));
    assert!(c.faults().encoder_jump);
}

#[test]
fn the_wheel_loop_commands_volts_whatever_the_supply() {
    // Holding 10 rad/s with the wheels turning at 10 rad/s: the same volts on 6 and on
    // 12 V, so half the duty.
    let run = |supply_v: f32| {
        let mut c = controller();
        c.seed_motion(BodyVelocity::new(0.325, 0.0));
        c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(10.0, 10.0)));
        // 10 rad/s is 2.29 ticks per step: whole ticks, the fraction carried.
        let per_step = 10.0 * 1440.0 / (core::f32::consts::TAU * 1000.0);
        let (mut counted, mut duty) = (0.0f32, MotorCommand::STOP);
        for k in 1..=200 {
            let n = (k as f32 * per_step) as i32 - counted as i32;
            counted += n as f32;
            duty = c.step(StepInput::on_time(ticks(n, n), supply_v));
        }
        (duty, c.telemetry().wheel_loop.volts.left_v)
    };
    let (duty6, volts6) = run(6.0);
    let (duty12, volts12) = run(12.0);
    assert!((volts6 - volts12).abs() < 1e-4, "{volts6} vs {volts12}");
    assert!((duty6.left - 2.0 * duty12.left).abs() < 1e-4);
    // About the feed-forward for 10 rad/s, 0.33 + 1.57 V: the PID only trims it.
    assert!((volts6 - 1.9).abs() < 0.15, "{volts6}");
}

#[test]
fn set_points_move_every_step_not_every_steering_period() {
    // From rest the tracking law asks for more than the 3 m/s² allow: the command grows
    // by a·T_s = 30 mm/s per 10 ms steering period, and the wheel set-points follow it
    // in ten equal steps of 0.092 rad/s (3 mm/s at the rim), not in one jump.
    let mut c = on_a_line(5.0);
    c.set_pose(Pose::new(-0.5, 0.0, 0.0));
    c.set_mode(Mode::FollowPath);
    // The first step holds the wheels at rest while the law runs.
    step(&mut c, ticks(0, 0));
    assert_eq!(c.telemetry().wheel_setpoint, WheelSpeeds::default());
    let mut previous = 0.0;
    for k in 0..40 {
        step(&mut c, ticks(0, 0));
        let w = c.telemetry().wheel_setpoint.left_rad_s;
        let change = w - previous;
        assert!(
            (change - 0.003 / 0.0325).abs() < 1e-3,
            "step {k}: {previous} → {w}"
        );
        previous = w;
    }
    assert!(c.telemetry().limit_flags.accel_limited);
    // A late step covers several periods of the ramp at once.
    c.step(StepInput {
        ticks: ticks(0, 0),
        periods: NonZeroU32::new(3).unwrap(),
        supply_v: SUPPLY_V,
        gyro: None,
        still: false,
    });
    let w = c.telemetry().wheel_setpoint.left_rad_s;
    assert!(
        (w - previous - 3.0 * 0.003 / 0.0325).abs() < 1e-3,
        "{previous} → {w}"
    );
}

#[test]
fn a_weak_supply_lowers_the_rim_speed_cap() {
    let mut c = controller();
    c.set_mode(Mode::FollowPath);
    c.step(StepInput::on_time(ticks(0, 0), 4.8));
    c.step(StepInput::on_time(ticks(0, 0), 4.8));
    // 0.85 · 4.8 V → 23.9 rad/s → 0.776 m/s at 32.5 mm, below the 1 m/s configured.
    let cap = c.telemetry().rim_speed_cap_m_s;
    assert!((cap - 0.7764).abs() < 1e-3, "{cap}");
    let mut strong = controller();
    strong.set_mode(Mode::FollowPath);
    strong.step(StepInput::on_time(ticks(0, 0), 12.0));
    strong.step(StepInput::on_time(ticks(0, 0), 12.0));
    // 0.85 · 6 V (the rated voltage caps a 12 V supply) → 30.4 rad/s → 0.987 m/s.
    let cap = strong.telemetry().rim_speed_cap_m_s;
    assert!((cap - 0.9874).abs() < 1e-3, "{cap}");
}

#[test]
fn seeding_a_motion_fills_the_speed_estimates() {
    let mut c = controller();
    c.seed_motion(BodyVelocity::new(0.4, 0.3));
    let w = c.telemetry().wheel_speed;
    // Inverse kinematics: (0.4 ∓ 0.0225)/0.0325 = 11.62 and 12.98 rad/s, to a tick.
    assert!((w.left_rad_s - 11.615).abs() < 0.22, "{w:?}");
    assert!((w.right_rad_s - 12.998).abs() < 0.22, "{w:?}");
}

#[test]
fn encoder_jump_latches_a_stop_until_cleared() {
    let mut c = controller();
    c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(5.0, 5.0)));
    assert!(step(&mut c, ticks(0, 0)).left > 0.0);
    let duty = step(&mut c, ticks(10_000, 0));
    assert!(c.faults().encoder_jump);
    assert_eq!(duty, MotorCommand::STOP);
    // Latched, even with sane input.
    assert_eq!(step(&mut c, ticks(0, 0)), MotorCommand::STOP);
    c.clear_faults();
    let duty = step(&mut c, ticks(0, 0));
    assert!(!c.faults().any());
    assert!(duty.left > 0.0);
}

#[test]
fn fault_flags_any() {
    let a = ControllerFaults {
        encoder_jump: true,
        non_finite: false,
    };
    let b = ControllerFaults {
        encoder_jump: false,
        non_finite: true,
    };
    assert!(!ControllerFaults::default().any());
    assert!(a.any() && b.any());
}

#[test]
fn hold_mode_caps_set_points_at_the_rim_speed_limit() {
    let mut c = controller();
    c.set_mode(Mode::HoldWheelSpeeds(WheelSpeeds::new(1000.0, -1000.0)));
    c.step(StepInput::on_time(ticks(0, 0), 12.0));
    // The 6 V motors reach 30.4 rad/s with 15 % of their voltage spare (0.987 m/s at
    // the rim), below the 1 m/s configured cap.
    let max = (0.85 * 6.0 - 0.33) / 0.157;
    assert!((c.telemetry().wheel_setpoint.left_rad_s - max).abs() < 1e-3);
    assert!((c.telemetry().wheel_setpoint.right_rad_s + max).abs() < 1e-3);
}

#[test]
fn open_loop_volts_reach_the_duty_directly() {
    let mut c = controller();
    c.set_mode(Mode::ApplyVolts(WheelVolts {
        left_v: 1.5,
        right_v: -1.5,
    }));
    // 1.5 V on 6 V, at once (no slew, no PID).
    let duty = step(&mut c, ticks(0, 0));
    assert_eq!(
        duty,
        MotorCommand {
            left: 0.25,
            right: -0.25
        }
    );
    c.set_mode(Mode::ApplyVolts(WheelVolts {
        left_v: 3.0,
        right_v: 0.0,
    }));
    assert_eq!(step(&mut c, ticks(0, 0)).left, 0.5);
}

#[test]
fn set_law_and_set_mode_take_effect() {
    let mut c = controller();
    c.set_law(LawKind::Kanayama).expect("owned outer loop");
    assert_eq!(c.law(), LawKind::Kanayama);
    c.set_mode(Mode::FollowPath);
    assert_eq!(c.mode(), Mode::FollowPath);
    step(&mut c, ticks(0, 0));
    step(&mut c, ticks(0, 0));
    // Kanayama's law reports no polar error; the paper's does.
    assert!(c.telemetry().law.polar.is_none());
    c.set_law(LawKind::Paper).expect("owned outer loop");
    for _ in 0..10 {
        step(&mut c, ticks(0, 0));
    }
    assert!(c.telemetry().law.polar.is_some());
    c.set_mode(Mode::Idle);
    assert_eq!(step(&mut c, ticks(0, 0)), MotorCommand::STOP);
}

proptest! {
    /// Any tick sequence, late steps and supply reading, however absurd, gives duties
    /// that are finite and in [−1, 1].
    #[test]
    fn any_input_gives_bounded_finite_duty(
        ticks in prop::collection::vec(
            prop_oneof![
                -50i32..50,
                Just(i32::MIN), Just(i32::MAX), any::<i32>()
            ],
            1..300,
        ),
        periods in prop::collection::vec(1u32..5, 1..10),
        supply in prop_oneof![
            Just(6.0f32), Just(12.6), Just(4.8), Just(0.0), Just(-3.0),
            Just(f32::NAN), Just(f32::INFINITY), prop::num::f32::ANY
        ],
        law in prop::sample::select(LawKind::ALL.to_vec()),
        pose in prop::option::of((
            prop::num::f32::ANY, prop::num::f32::ANY, prop::num::f32::ANY
        )),
    ) {
        let mut c = controller();
        c.set_law(law).expect("owned outer loop");
        c.set_mode(Mode::FollowPath);
        // Also a pose fix that is NaN, infinite or huge.
        if let Some((x, y, th)) = pose {
            c.set_pose(Pose::new(x, y, th));
        }
        for (k, pair) in ticks.chunks(2).enumerate() {
            let t = TickDeltas { left: pair[0], right: *pair.last().unwrap_or(&0) };
            let n = periods[k % periods.len()];
            let duty = c.step(StepInput {
                ticks: t,
                periods: NonZeroU32::new(n).unwrap_or(NonZeroU32::MIN),
                supply_v: supply,
                gyro: None,
                still: false,
            });
            for d in [duty.left, duty.right] {
                prop_assert!(d.is_finite() && (-1.0..=1.0).contains(&d));
            }
            if !c.telemetry().pose.is_finite() {
                prop_assert!(c.faults().any());
                prop_assert_eq!(duty, MotorCommand::STOP);
            }
        }
    }
}

#[test]
fn the_odometry_heading_is_the_encoders_own() {
    // Turning on the spot, left back and right forward: without a gyro the pose's
    // heading is odometry's.
    let mut c = controller();
    for _ in 0..200 {
        step(&mut c, ticks(-1, 1));
    }
    let heading = c.odometry_heading_rad();
    assert!(heading > 0.05, "{heading}");
    assert_eq!(heading, c.pose().theta_rad);
    assert_eq!(
        heading,
        c.fused_heading_rad(),
        "no gyro: the fused heading is odometry's"
    );
}

#[test]
fn after_a_resync_the_estimate_does_not_depend_on_how_long_the_robot_stood() {
    // The same drive, after standing 10 and 37 steps (different phases of the heading's
    // periodic recomputation), resynced before it: bit-identical poses.
    let drive = |stood: u32| {
        let mut c = controller();
        for _ in 0..30 {
            step(&mut c, ticks(2, 3));
        }
        for _ in 0..stood {
            step(&mut c, ticks(0, 0));
        }
        c.resync_heading();
        for k in 0..500 {
            step(&mut c, ticks(3 + (k % 2), 2 + (k % 5)));
        }
        let p = c.pose();
        [p.x_m, p.y_m, p.theta_rad].map(f32::to_bits)
    };
    assert_eq!(drive(10), drive(37));
}
