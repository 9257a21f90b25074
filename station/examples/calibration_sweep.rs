//! Before/after table of UMBmark calibration over drawn robots.
//!
//! `cargo run --release -p station --example calibration_sweep -- [robots] [slip]`
//!
//! Each robot is drawn from paper-circle's `[sweep]` spreads (radius ±1 %, left/right
//! ±0.5 %, track ±2 %, supply, friction, encoder jitter, start pose; slip 0 unless `slip`
//! is given; start pose exact unless `placement` is given), calibrated by the station's own procedure against its virtual robot
//! (5 squares each way, 2 m, end points measured with 2 mm noise, straight 2 m run
//! against a tape read to 1 mm), and then run on paper-circle: uncalibrated (the nominal
//! geometry), calibrated, and with the geometry known exactly (what is left is slip and
//! everything else). Prints the true final position error's percentiles.

#[path = "../tests/support/mod.rs"]
mod support;

use std::sync::atomic::{AtomicUsize, Ordering};

use controller_core::law::LawKind;
use host_sim::run::{plant_params, run_scenario_with, RunOptions};
use host_sim::serve::VirtualRobot;
use host_sim::sweep::{perturb, Percentiles};
use link::ParamSet;
use robot_app::Channels;
use robot_files::rng::Rng;
use robot_files::scenario::Scenario;
use station::calibrate::{calibrate, CalibrateArgs, Measure};
use station::client::Client;
use support::InProcess;

/// `scenario` with the controller believing `robot`, the plant's true geometry unchanged.
fn believing(scenario: &Scenario, robot: controller_core::params::RobotConfig) -> Scenario {
    let truth = plant_params(scenario).geometry;
    let mut s = scenario.clone();
    s.robot = robot;
    let a = truth.wheel_radius_left_m / f64::from(robot.wheel_radius_left_m) - 1.0;
    let b = truth.wheel_radius_right_m / f64::from(robot.wheel_radius_right_m) - 1.0;
    s.plant.mismatch.wheel_radius_pct = 50.0 * (a + b);
    s.plant.mismatch.wheel_radius_left_right_pct = 100.0 * (a - b);
    s.plant.mismatch.track_width_pct =
        (truth.track_width_m / f64::from(robot.track_width_m) - 1.0) * 100.0;
    s
}

fn final_error(scenario: &Scenario) -> f64 {
    run_scenario_with(scenario, LawKind::Tracking, RunOptions::default()).map_or(f64::NAN, |r| {
        r.summary.headline_error().final_position_error_m
    })
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let robots: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(200);
    let slip = args.iter().any(|a| a == "slip");
    let mut base = Scenario::load("paper-circle").expect("built in");
    if !slip {
        base.sweep.slip_max = 0.0;
    }
    // Placement is not odometry: a robot put down 0.1 m or 0.2 rad off its start mark
    // follows a shifted circle whatever its geometry. The draws keep the start exact
    // (pass `placement` to draw it too).
    if !args.iter().any(|a| a == "placement") {
        base.sweep.start_position_m = 0.0;
        base.sweep.start_heading_rad = 0.0;
    }
    let square_base = Scenario::load("square-waypoints").expect("built in");
    let next = AtomicUsize::new(0);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let started = std::time::Instant::now();
    let rows: Vec<(f64, f64, f64, f64, f64)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut out = Vec::new();
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        if i >= robots {
                            break;
                        }
                        let mut rng = Rng::new(1 ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                        let (mut drawn, _) = perturb(&base, &mut rng);
                        drawn.seed = rng.next_u64();
                        // The same robot on the calibration floor: its plant, the squares.
                        let mut floor = square_base.clone();
                        floor.robot = drawn.robot;
                        floor.plant = drawn.plant;
                        let mut channels = Channels::new();
                        let Ok(mut robot) = VirtualRobot::new(&mut channels, &floor) else {
                            continue;
                        };
                        let mut client = Client::new(InProcess::new(&mut robot));
                        let calib = CalibrateArgs {
                            side_m: 2.0,
                            runs: 5,
                            straight_m: 2.0,
                            measurements: None,
                            simulated_noise_m: Some(0.002),
                            no_persist: true,
                        };
                        let mut noise = Rng::new(rng.next_u64());
                        let mut measure = Measure::Simulated {
                            noise_m: 0.002,
                            rng: &mut noise,
                        };
                        let Ok(outcome) =
                            calibrate(&mut client, &floor, &calib, &mut measure, &mut |_| {})
                        else {
                            continue;
                        };
                        let truth = plant_params(&drawn).geometry;
                        let mut exact = drawn.robot;
                        exact.wheel_radius_left_m = truth.wheel_radius_left_m as f32;
                        exact.wheel_radius_right_m = truth.wheel_radius_right_m as f32;
                        exact.track_width_m = truth.track_width_m as f32;
                        let after: ParamSet = outcome.after;
                        let ratio = (f64::from(after.robot.wheel_radius_right_m)
                            / f64::from(after.robot.wheel_radius_left_m))
                            / (truth.wheel_radius_right_m / truth.wheel_radius_left_m)
                            - 1.0;
                        let track =
                            f64::from(after.robot.track_width_m) / truth.track_width_m - 1.0;
                        out.push((
                            final_error(&drawn),
                            final_error(&believing(&drawn, after.robot)),
                            final_error(&believing(&drawn, exact)),
                            ratio.abs() * 100.0,
                            track.abs() * 100.0,
                        ));
                    }
                    out
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().unwrap_or_default())
            .collect()
    });
    let col =
        |f: fn(&(f64, f64, f64, f64, f64)) -> f64| -> Vec<f64> { rows.iter().map(f).collect() };
    let show = |name: &str, v: Vec<f64>, unit: &str| {
        if let Some(p) = Percentiles::of(&v) {
            println!(
                "{name:<44} p50 {:.4}{unit}  p90 {:.4}{unit}  max {:.4}{unit}",
                p.p50, p.p90, p.max
            );
        }
    };
    println!(
        "{} of {robots} drawn robots calibrated (slip {}), {:.0} s on {threads} threads; paper-circle, true final position error:",
        rows.len(),
        if slip { "on, 0…1 % per wheel" } else { "off" },
        started.elapsed().as_secs_f64()
    );
    show("uncalibrated (nominal geometry)", col(|r| r.0), " m");
    show(
        "calibrated (UMBmark through the station)",
        col(|r| r.1),
        " m",
    );
    show("geometry known exactly", col(|r| r.2), " m");
    show("|recovered R_right/R_left − true|", col(|r| r.3), " %");
    show("|recovered track − true|", col(|r| r.4), " %");
}
