use super::*;

const LIMITS: VelocityModeConfig = VelocityModeConfig {
    linear_x: AxisLimits {
        max_velocity: 0.5,
        max_acceleration: 1.0,
        max_jerk: 10.0,
    },
    angular_z: AxisLimits {
        max_velocity: 3.0,
        max_acceleration: 10.0,
        max_jerk: 100.0,
    },
    cmd_vel_timeout_steps: 500,
};
const T: f32 = 0.001;
const TRACK_M: f32 = 0.15;

/// Steps `source` `n` times without a new command; the limited commands.
fn run(source: &mut VelocitySource, n: usize, cap: f32) -> Vec<BodyVelocity> {
    (0..n).map(|_| source.step(1, T, TRACK_M, cap).0).collect()
}

/// Largest |Δ| and |Δ²| per second (acceleration and jerk) of one axis of `commands`,
/// starting from rest.
fn derivatives(commands: &[f32]) -> (f32, f32) {
    let mut v = vec![0.0, 0.0];
    v.extend_from_slice(commands);
    let a: Vec<f32> = v.windows(2).map(|w| (w[1] - w[0]) / T).collect();
    let max_a = a.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    let max_j = a
        .windows(2)
        .map(|w| ((w[1] - w[0]) / T).abs())
        .fold(0.0f32, f32::max);
    (max_a, max_j)
}

#[test]
fn a_step_ramps_within_the_limits_and_settles_without_overshoot() {
    let mut source = VelocitySource::new(LIMITS);
    source.command(BodyVelocity::new(0.4, -2.0));
    let first = source.step(1, T, TRACK_M, 10.0);
    assert!(
        first.0.v_m_s > 0.0,
        "changes in the step the command arrives"
    );
    assert!(first.0.omega_rad_s < 0.0, "with the command's sign");
    assert!(first.1.accel_limited);
    let mut all = vec![first.0];
    for _ in 0..700 {
        source.command(BodyVelocity::new(0.4, -2.0));
        all.extend(run(&mut source, 1, 10.0));
    }
    let v: Vec<f32> = all.iter().map(|c| c.v_m_s).collect();
    let w: Vec<f32> = all.iter().map(|c| c.omega_rad_s).collect();
    let (a, j) = derivatives(&v);
    assert!(a <= 1.0 + 1e-3, "linear acceleration {a}");
    assert!(j <= 10.0 * 1.01, "linear jerk {j}");
    let (a, j) = derivatives(&w);
    assert!(a <= 10.0 + 1e-2, "angular acceleration {a}");
    assert!(j <= 100.0 * 1.01, "angular jerk {j}");
    assert!(v.iter().all(|x| *x <= 0.4 + 1e-6), "no overshoot");
    assert!(w.iter().all(|x| *x >= -2.0 - 1e-6), "no overshoot");
    assert!((source.limited().v_m_s - 0.4).abs() < 1e-5, "arrives");
    assert!((source.limited().omega_rad_s + 2.0).abs() < 1e-5, "arrives");
    // Ramping at 1 m/s² from rest to 0.4 m/s takes more than 0.4 s (plus the jerk's).
    assert!(v[350] < 0.4, "the acceleration limit acted");
}

#[test]
fn commands_beyond_the_velocity_limit_are_clamped() {
    let mut source = VelocitySource::new(LIMITS);
    for _ in 0..2000 {
        source.command(BodyVelocity::new(-9.0, 9.0));
        source.step(1, T, TRACK_M, 100.0);
    }
    assert!((source.limited().v_m_s + 0.5).abs() < 1e-5);
    assert!((source.limited().omega_rad_s - 3.0).abs() < 1e-5);
}

#[test]
fn the_command_times_out_and_ramps_to_a_stop() {
    let mut source = VelocitySource::new(LIMITS);
    source.command(BodyVelocity::new(0.3, 0.0));
    let cruise = run(&mut source, 499, 10.0);
    assert!(
        !source.timed_out(),
        "in force for 500 steps from its arrival"
    );
    let at_speed = cruise[498].v_m_s;
    assert!((at_speed - 0.3).abs() < 1e-5);
    let last_in_force = source.step(1, T, TRACK_M, 10.0).0;
    assert_eq!(last_in_force.v_m_s, at_speed, "still holding at step 500");
    assert!(source.timed_out());
    let stopping = run(&mut source, 1000, 10.0);
    assert!(stopping[0].v_m_s < at_speed, "ramps down at once");
    assert!(stopping[5].v_m_s > 0.25, "a ramp, not a jump");
    assert_eq!(stopping[999], BodyVelocity::new(0.0, 0.0), "stopped");
    assert!(
        stopping.iter().all(|c| c.v_m_s >= -1e-5),
        "without reversing"
    );
    // A new command brings it back.
    source.command(BodyVelocity::new(0.1, 0.0));
    assert!(source.step(1, T, TRACK_M, 10.0).0.v_m_s > 0.0);
}

#[test]
fn the_rim_speed_cap_keeps_the_curvature_of_the_command() {
    let mut source = VelocitySource::new(LIMITS);
    // Rim speeds 0.4 ± 1.0·0.075: a cap of 0.2 scales both by 0.2/0.475.
    for _ in 0..2000 {
        source.command(BodyVelocity::new(0.4, 1.0));
        source.step(1, T, TRACK_M, 0.2);
    }
    let c = source.limited();
    assert!(
        (c.omega_rad_s / c.v_m_s - 2.5).abs() < 1e-3,
        "ω/v kept: {c:?}"
    );
    assert!(c.v_m_s.abs() + 0.5 * c.omega_rad_s.abs() * TRACK_M <= 0.2 + 1e-6);
    // The cap falls mid-run: it wins at once.
    let (c, flags) = source.step(1, T, TRACK_M, 0.1);
    assert!(flags.rim_speed_capped);
    assert!(c.v_m_s.abs() + 0.5 * c.omega_rad_s.abs() * TRACK_M <= 0.1 + 1e-6);
}

#[test]
fn a_restart_continues_from_the_measured_motion_with_no_command() {
    let mut source = VelocitySource::new(LIMITS);
    source.command(BodyVelocity::new(0.4, 0.0));
    source.restart(BodyVelocity::new(0.2, 0.5));
    assert!(source.timed_out(), "the old command is gone");
    let (c, _) = source.step(1, T, TRACK_M, 10.0);
    assert!(
        c.v_m_s < 0.2 && c.v_m_s > 0.19,
        "slows from where it was: {c:?}"
    );
    assert!(c.omega_rad_s < 0.5 && c.omega_rad_s > 0.49);
}

#[test]
fn a_late_step_advances_by_the_periods_it_covered() {
    let mut source = VelocitySource::new(LIMITS);
    source.command(BodyVelocity::new(0.4, 0.0));
    source.step(498, T, TRACK_M, 10.0);
    assert!(!source.timed_out());
    source.step(2, T, TRACK_M, 10.0);
    assert!(source.timed_out(), "500 periods old");
}

#[test]
fn a_non_finite_command_gives_a_non_finite_command_and_no_panic() {
    let mut source = VelocitySource::new(LIMITS);
    source.command(BodyVelocity::new(f32::NAN, 0.0));
    let (c, _) = source.step(1, T, TRACK_M, 10.0);
    assert!(!c.v_m_s.is_finite());
}

#[test]
fn the_settings_are_checked_by_name() {
    let mut config = LIMITS;
    assert_eq!(config.validate(), Ok(()));
    config.angular_z.max_jerk = 0.0;
    assert_eq!(
        config.validate().map_err(|e| e.field()),
        Err("velocity.angular_z.max_jerk")
    );
    config = LIMITS;
    config.linear_x.max_velocity = f32::INFINITY;
    assert_eq!(
        config.validate().map_err(|e| e.field()),
        Err("velocity.linear_x.max_velocity")
    );
    config = LIMITS;
    config.cmd_vel_timeout_steps = 0;
    assert_eq!(
        config.validate().map_err(|e| e.field()),
        Err("velocity.cmd_vel_timeout_steps")
    );
    assert_eq!(VelocityModeConfig::at_rate(1000).cmd_vel_timeout_steps, 500);
    assert_eq!(VelocityModeConfig::at_rate(1).cmd_vel_timeout_steps, 1);
}
