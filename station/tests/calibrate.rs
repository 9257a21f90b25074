//! UMBmark through the station against the virtual robot with injected mismatches: the
//! recovered geometry against the plant's truth, and runs the line cuts short.

mod support;

use host_sim::serve::VirtualRobot;
use link::ParamSet;
use robot_app::Channels;
use robot_files::rng::Rng;
use robot_files::scenario::Scenario;
use station::calibrate::Measure;
use station::calibrate::{calibrate, CalibrateArgs, Outcome};
use station::client::Client;
use support::{InProcess, LineFaults};

/// What a calibration of a robot with these mismatches (%), on this line, did: its
/// outcome or error, its progress lines, the configuration the robot runs after it, the
/// one before, and the one persisted.
struct Calibration {
    outcome: Result<Outcome, String>,
    lines: Vec<String>,
    active: ParamSet,
    before: ParamSet,
    persisted: Option<ParamSet>,
    true_ratio: f64,
    true_track_m: f64,
}

fn calibration(left_right_pct: f64, track_pct: f64, faults: LineFaults) -> Calibration {
    let mut base = Scenario::load("square-waypoints").expect("built in");
    base.plant.mismatch.wheel_radius_left_right_pct = left_right_pct;
    base.plant.mismatch.track_width_pct = track_pct;
    let truth = host_sim::run::plant_params(&base).geometry;
    let mut channels = Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &base).expect("valid");
    let before = *robot.link().active_params();
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
    let mut lines = Vec::new();
    let outcome = {
        let mut pipe = InProcess::new(&mut robot);
        pipe.faults = faults;
        let mut client = Client::new(pipe);
        calibrate(&mut client, &base, &args, &mut measure, &mut |l| {
            lines.push(l.to_string())
        })
        .map_err(|e| e.to_string())
    };
    Calibration {
        outcome,
        lines,
        active: *robot.link().active_params(),
        before,
        persisted: robot.persisted().copied(),
        true_ratio: truth.wheel_radius_right_m / truth.wheel_radius_left_m,
        true_track_m: truth.track_width_m,
    }
}

/// The calibrated ratio's and track's errors, %.
fn errors(c: &Calibration) -> (f64, f64) {
    let outcome = c.outcome.as_ref().expect("calibrates");
    let a = outcome.after.robot;
    let ratio = f64::from(a.wheel_radius_right_m) / f64::from(a.wheel_radius_left_m);
    (
        (ratio / c.true_ratio - 1.0) * 100.0,
        (f64::from(a.track_width_m) / c.true_track_m - 1.0) * 100.0,
    )
}

#[test]
fn umbmark_recovers_the_radius_ratio_and_the_track() {
    for (lr, track) in [(1.0, 5.0), (-1.0, -5.0), (0.5, -3.0)] {
        let c = calibration(lr, track, LineFaults::default());
        let (ratio_err, track_err) = errors(&c);
        let e = c.outcome.as_ref().expect("calibrates").estimate;
        let jung_chung = e.jung_chung_e_b.expect("headings measured");
        println!(
            "L/R {lr:+}%, track {track:+}%: ratio off {ratio_err:+.4}%, track off {track_err:+.4}%, \
E_b {:.5}, Jung & Chung {jung_chung:.5}",
            e.e_b
        );
        // The headings are measured to 0.2° (1σ), three runs each way: E_b to about
        // 0.03 % (1σ).
        assert!(
            (jung_chung / e.e_b - 1.0).abs() < 1.5e-3,
            "Jung & Chung's E_b {jung_chung} against the fit's {}",
            e.e_b
        );
        assert!(
            ratio_err.abs() <= 0.05,
            "ratio off by {ratio_err}% (L/R {lr}%, track {track}%)"
        );
        assert!(
            track_err.abs() <= 0.3,
            "track off by {track_err}% (L/R {lr}%, track {track}%)"
        );
        assert_eq!(c.persisted, Some(c.active), "the result is persisted");
    }
}

#[test]
fn a_square_the_link_cut_short_is_driven_again() {
    // The second clockwise square: heartbeats stop reaching the robot 5 s into it.
    let c = calibration(
        0.5,
        -3.0,
        LineFaults {
            mute_heartbeats: vec![(2, 5000)],
            ..LineFaults::default()
        },
    );
    let (ratio_err, track_err) = errors(&c);
    assert!(ratio_err.abs() <= 0.05, "ratio off by {ratio_err}%");
    assert!(track_err.abs() <= 0.3, "track off by {track_err}%");
    let said = c.lines.join("\n");
    assert!(
        said.contains("clockwise square 2/3") && said.contains("again"),
        "the repeat is announced: {said}"
    );
    assert!(said.contains("LinkLost"), "with the reason: {said}");
    assert_eq!(c.persisted, Some(c.active));
}

#[test]
fn a_run_cut_short_twice_stops_the_calibration_and_persists_nothing() {
    // A square, then the straight run (the seventh and eighth armings of 3 + 3 squares).
    for (armings, run) in [((2, 3), "clockwise square 2/3"), ((7, 8), "straight run")] {
        let c = calibration(
            0.5,
            -3.0,
            LineFaults {
                mute_heartbeats: vec![(armings.0, 5000), (armings.1, 5000)],
                ..LineFaults::default()
            },
        );
        let error = c.outcome.expect_err("the calibration stops");
        assert!(error.contains(run), "names the run: {error}");
        assert!(error.contains("LinkLost"), "and why: {error}");
        assert_eq!(c.persisted, None, "nothing persisted");
        assert_eq!(c.active, c.before, "the robot's geometry is as before");
    }
}
