//! Closed loop on a plain unicycle: the steering laws against the paper's circle.
//!
//! The plant is eq. (5) integrated exactly along an arc for each steering period; the
//! law's command (after the rim-speed cap and acceleration limits of the reference robot)
//! is applied as is. No motors, no encoders: this isolates the laws. The full stack is
//! exercised by `host-sim`.

use core::num::NonZeroU32;

use controller_core::law::{self, LawKind};
use controller_core::limits::CommandLimiter;
use controller_core::math;
use controller_core::prelude::*;
use controller_core::time::StepClock;

/// The paper's circle: r = 1.25 m about the origin, counter-clockwise, with the consistent
/// pair v_r = 0.25 m/s, ω_r = 0.2 rad/s. The reference starts at the point of the circle
/// nearest the robot's start (−1, −1.2, 2π/3).
fn paper_circle(mode: ReferenceMode) -> Reference {
    let start_angle = math::atan2(-1.2, -1.0);
    let circle = Path::circle(Point::new(0.0, 0.0), 1.25, start_angle, true).unwrap();
    Reference::new(circle, 0.25, mode).unwrap()
}

const START: Pose = Pose {
    x_m: -1.0,
    y_m: -1.2,
    theta_rad: 2.0 * core::f32::consts::FRAC_PI_3,
};

/// Exact unicycle step along an arc of curvature ω/v for `dt` seconds.
fn unicycle(p: Pose, cmd: BodyVelocity, dt: f32) -> Pose {
    let ds = cmd.v_m_s * dt;
    let dth = cmd.omega_rad_s * dt;
    let chord = ds * math::sinc(0.5 * dth);
    let (s, c) = math::sin_cos(p.theta_rad + 0.5 * dth);
    Pose::new(p.x_m + chord * c, p.y_m + chord * s, p.theta_rad + dth)
}

struct Run {
    /// (time s, position error m, |heading error| rad, distance r_e m) per steering step.
    samples: Vec<(f32, f32, f32, f32)>,
}

impl Run {
    fn tail(&self, from_s: f32) -> impl Iterator<Item = &(f32, f32, f32, f32)> {
        self.samples.iter().filter(move |s| s.0 >= from_s)
    }
}

fn run(law: LawKind, mode: ReferenceMode, seconds: u32) -> Run {
    let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
    let config = params.config();
    let mut reference = paper_circle(mode);
    let mut limiter = CommandLimiter::new(config.limits);
    // The robot starts moving at v = 0.4 m/s, ω = 0.3 rad/s (paper, section 4).
    limiter.reset(BodyVelocity::new(0.4, 0.3));
    let period = params.steering_period_s();
    let rate = config.control_rate_hz / config.steering_divider;
    let mut clock = StepClock::new(NonZeroU32::new(rate).unwrap());
    let mut pose = START;
    let mut samples = Vec::new();
    for _ in 0..seconds * rate {
        let elapsed = u32::from(clock.steps() != 0);
        let r = reference.sample(elapsed, NonZeroU32::new(rate).unwrap(), &pose);
        let out = law::steer(law, &config.law, &pose, &r);
        let (cmd, _) = limiter.apply(
            out.command,
            period,
            params.geometry().track_width_m(),
            config.limits.max_rim_speed_m_s,
        );
        let e = controller_core::kinematics::tracking_error(&pose, &r.pose);
        samples.push((
            clock.elapsed_s(),
            e.position_m(),
            e.theta_e_rad.abs(),
            out.error.position_m(),
        ));
        pose = unicycle(pose, cmd, period);
        clock.tick();
    }
    Run { samples }
}

const TIME_INDEXED: ReferenceMode = ReferenceMode::TimeIndexed {
    start_offset_m: 0.0,
};

#[test]
fn paper_law_settles_at_a_lag_near_v_r_over_gamma() {
    let gamma = RobotConfig::REFERENCE_ROBOT.law.paper.gamma;
    let expected = 0.25 / gamma;
    let result = run(LawKind::Paper, TIME_INDEXED, 60);
    let lags: Vec<f32> = result.tail(40.0).map(|s| s.3).collect();
    let mean = lags.iter().sum::<f32>() / lags.len() as f32;
    let spread = lags.iter().fold(0.0f32, |m, &l| m.max((l - mean).abs()));
    println!("paper law: steady lag {mean:.4} m (v_r/γ = {expected:.4} m), spread {spread:.2e}");
    assert!(
        (mean - expected).abs() <= 0.1 * expected,
        "lag {mean} vs {expected}"
    );
    // It is a steady lag, not a slow convergence.
    assert!(spread < 0.01 * expected);
}

fn assert_converges(law: LawKind, mode: ReferenceMode) {
    let result = run(law, mode, 40);
    let worst_position = result.tail(30.0).fold(0.0f32, |m, s| m.max(s.1));
    let worst_heading = result.tail(30.0).fold(0.0f32, |m, s| m.max(s.2));
    let settled = result
        .samples
        .iter()
        .rposition(|s| s.1 >= 0.01 || s.2 >= 1f32.to_radians())
        .map_or(0.0, |i| result.samples[i].0);
    println!(
        "{}: settled (1 cm, 1 deg) after {settled:.2} s; after 30 s, position error ≤ \
         {worst_position:.2e} m, heading error ≤ {:.2e} deg",
        law.name(),
        worst_heading.to_degrees()
    );
    assert!(worst_position < 0.01, "position error {worst_position} m");
    assert!(
        worst_heading < 1f32.to_radians(),
        "heading error {worst_heading} rad"
    );
}

#[test]
fn tracking_law_reaches_zero_error_on_the_moving_reference() {
    assert_converges(LawKind::Tracking, TIME_INDEXED);
}

#[test]
fn kanayama_law_reaches_zero_error_on_the_moving_reference() {
    assert_converges(LawKind::Kanayama, TIME_INDEXED);
}

#[test]
fn tracking_law_follows_the_path_without_a_time_index() {
    assert_converges(
        LawKind::Tracking,
        ReferenceMode::PathFollowing { lookahead_m: 0.0 },
    );
}

/// docs/paper-errata.md, item 3: adding feed-forward of (v_r, ω_r) to
/// (33)–(34) drives r_e to zero but leaves the heading uncontrolled, because α and β are
/// undefined at r_e = 0. This measures it, so the `tracking` law's reason to exist is a
/// number, not a claim.
#[test]
fn naive_feed_forward_on_the_paper_law_leaves_a_heading_error() {
    let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
    let config = params.config();
    let mut reference = paper_circle(TIME_INDEXED);
    let period = params.steering_period_s();
    let rate = config.control_rate_hz / config.steering_divider;
    let mut clock = StepClock::new(NonZeroU32::new(rate).unwrap());
    let mut limiter = CommandLimiter::new(config.limits);
    let mut pose = START;
    let mut tail = Vec::new();
    for _ in 0..60 * rate {
        let elapsed = u32::from(clock.steps() != 0);
        let r = reference.sample(elapsed, NonZeroU32::new(rate).unwrap(), &pose);
        let paper = law::steer(LawKind::Paper, &config.law, &pose, &r).command;
        let naive = BodyVelocity::new(paper.v_m_s + r.v_m_s, paper.omega_rad_s + r.omega_rad_s);
        let (cmd, _) = limiter.apply(
            naive,
            period,
            params.geometry().track_width_m(),
            config.limits.max_rim_speed_m_s,
        );
        if clock.elapsed_s() >= 40.0 {
            let e = controller_core::kinematics::tracking_error(&pose, &r.pose);
            tail.push((e.position_m(), e.theta_e_rad.abs()));
        }
        pose = unicycle(pose, cmd, period);
        clock.tick();
    }
    let position = tail.iter().fold(0.0f32, |m, e| m.max(e.0));
    let heading = tail.iter().fold(0.0f32, |m, e| m.max(e.1)).to_degrees();
    let mean_heading = (tail.iter().map(|e| e.1).sum::<f32>() / tail.len() as f32).to_degrees();
    println!(
        "naive feed-forward: position error ≤ {position:.4} m, heading error ≤ {heading:.2} deg \
         (mean {mean_heading:.2} deg)"
    );
    // The position error becomes small but the heading error does not go to zero.
    assert!(heading > 1.0, "heading error {heading} deg");
}
