//! The gyro's warnings and the disagreement fault: a failed gyro warns once and never
//! stops the robot; a persistent disagreement warns, or stops the robot when configured
//! to.

use super::*;
use crate::gyro::{GyroFailure, GyroSample};
use crate::law::LawKind;
use crate::params::RobotConfig;

/// A moving rig whose gyro reads `yaw_rate_radps` every step while odometry drives
/// straight, armed in motion, with the disagreement configured to stop or not.
fn armed_with_gyro(yaw_rate_radps: f32, disagreement_stops: bool) -> Rig {
    let mut r = moving_rig();
    let mut robot = RobotConfig::REFERENCE_ROBOT;
    robot.gyro.disagreement_stops = disagreement_stops;
    let params = Params::new(robot).unwrap();
    r.ctl.rebuild(&params, LawKind::Tracking).unwrap();
    r.gyro = Some(GyroSample {
        yaw_rate_radps,
        age_periods: 0,
    });
    let mut request = ArmRequest::follow_path();
    request.initial_motion = Some(BodyVelocity::new(0.1625, 0.0));
    // At the robot (no link, so no heartbeat is due).
    assert_eq!(
        r.sup.arm_locally(&mut r.ctl, request),
        Ok(Event::Armed(RunMode::FollowPath))
    );
    r
}

#[test]
fn a_persistent_disagreement_warns_once_and_the_robot_drives_on() {
    // 0.3 rad/s against odometry's 0: the 10 s running mean passes 0.03 rad/s after
    // about 1.05 s (0.3 · (1 − e^(−t/10))).
    let mut r = armed_with_gyro(0.3, false);
    let outs = r.run(3000);
    let warned: Vec<usize> = (0..outs.len())
        .filter(|&k| outs[k].event == Some(Event::GyroDisagrees))
        .collect();
    assert_eq!(warned.len(), 1, "{:?}", events(&outs));
    assert!(
        (1000..1150).contains(&warned[0]),
        "warned at step {}",
        warned[0]
    );
    assert!(outs.iter().all(|o| o.state == State::Armed));
    assert!(!outs[2999].faults.any());
}

#[test]
fn configured_to_stop_a_disagreement_faults_the_robot() {
    let mut r = armed_with_gyro(0.3, true);
    let outs = r.run(3000);
    let at = outs
        .iter()
        .position(|o| o.state == State::Faulted)
        .expect("faulted");
    assert!((1000..1150).contains(&at), "faulted at step {at}");
    assert!(outs[at].faults.has(Fault::HeadingDisagreement));
    assert_eq!(outs[at].event, Some(Event::Faulted));
    assert!(!events(&outs).contains(&Event::GyroDisagrees));
}

#[test]
fn a_gyro_that_stops_reading_warns_once_and_never_stops_the_robot() {
    let mut r = armed_with_gyro(0.0, true);
    r.run(100);
    r.gyro = None;
    let outs = r.run(2000);
    let limit = usize::from(RobotConfig::REFERENCE_ROBOT.gyro.absent_limit_steps);
    let warned: Vec<usize> = (0..outs.len())
        .filter(|&k| outs[k].event == Some(Event::GyroFailed(GyroFailure::Absent)))
        .collect();
    assert_eq!(warned.len(), 1, "{:?}", events(&outs));
    assert!(warned[0] <= limit, "warned at step {}", warned[0]);
    assert!(outs
        .iter()
        .all(|o| o.state == State::Armed && !o.faults.any()));
}

#[test]
fn holding_wheel_speeds_on_the_bench_ignores_the_disagreement() {
    // Wheels in the air: odometry sees them turn, the gyro sees no turn at all. The
    // bench's modes neither fault nor warn for it.
    let mut r = moving_rig();
    let mut robot = RobotConfig::REFERENCE_ROBOT;
    robot.gyro.disagreement_stops = true;
    r.ctl
        .rebuild(&Params::new(robot).unwrap(), LawKind::Tracking)
        .unwrap();
    r.moving = false;
    r.long_press_to_hold();
    r.press(SHORT);
    // Reading only from arming on (at rest, the bias estimate would take the rate in).
    r.gyro = Some(GyroSample {
        yaw_rate_radps: 0.3,
        age_periods: 0,
    });
    r.moving = true;
    let outs = r.run(3000);
    assert!(
        outs.iter().all(|o| o.state == State::Armed),
        "{:?}",
        events(&outs)
    );
    assert!(outs.iter().all(|o| !o.faults.any()));
    assert!(!events(&outs).contains(&Event::GyroDisagrees));
    assert!(
        r.ctl.telemetry().gyro.disagrees,
        "the check itself did see it"
    );
}
