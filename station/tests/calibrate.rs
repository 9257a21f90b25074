//! UMBmark through the station against the virtual robot with injected mismatches: the
//! recovered geometry against the plant's truth.

mod support;

use host_sim::serve::VirtualRobot;
use robot_app::Channels;
use robot_files::rng::Rng;
use robot_files::scenario::Scenario;
use station::calibrate::{calibrate, CalibrateArgs, Measure};
use station::client::Client;
use support::InProcess;

fn calibrated(left_right_pct: f64, track_pct: f64) -> (f64, f64, f64, f64) {
    let mut base = Scenario::load("square-waypoints").expect("built in");
    base.plant.mismatch.wheel_radius_left_right_pct = left_right_pct;
    base.plant.mismatch.track_width_pct = track_pct;
    let truth = host_sim::run::plant_params(&base).geometry;
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &base).expect("valid");
    let mut client = Client::new(InProcess::new(&mut robot));
    let args = CalibrateArgs {
        side_m: 2.0,
        runs: 3,
        straight_m: 2.0,
        measurements: None,
        simulated_noise_m: Some(0.002),
        no_persist: false,
    };
    let mut rng = Rng::new(7);
    let mut measure = Measure::Simulated {
        noise_m: 0.002,
        rng: &mut rng,
    };
    let outcome =
        calibrate(&mut client, &base, &args, &mut measure, &mut |_| {}).expect("calibrates");
    let a = outcome.after.robot;
    let ratio = f64::from(a.wheel_radius_right_m) / f64::from(a.wheel_radius_left_m);
    let true_ratio = truth.wheel_radius_right_m / truth.wheel_radius_left_m;
    (
        ratio,
        true_ratio,
        f64::from(a.track_width_m),
        truth.track_width_m,
    )
}

#[test]
fn umbmark_recovers_the_radius_ratio_and_the_track() {
    for (lr, track) in [(1.0, 5.0), (-1.0, -5.0), (0.5, -3.0)] {
        let (ratio, true_ratio, l, true_l) = calibrated(lr, track);
        let ratio_err = (ratio / true_ratio - 1.0) * 100.0;
        let track_err = (l / true_l - 1.0) * 100.0;
        println!(
            "L/R {lr:+}%, track {track:+}%: ratio off {ratio_err:+.4}%, track off {track_err:+.4}%"
        );
        assert!(
            ratio_err.abs() <= 0.05,
            "ratio off by {ratio_err}% (L/R {lr}%, track {track}%)"
        );
        assert!(
            track_err.abs() <= 0.3,
            "track off by {track_err}% (L/R {lr}%, track {track}%)"
        );
    }
}
