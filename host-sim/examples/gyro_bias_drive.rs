//! A 10-minute drive on a gyro with a 0.5 °/s turn-on bias: the heading error at the end,
//! with the bias learned during 5 s at rest before arming, and without the rest.
//!
//! ```text
//! cargo run --release -p host-sim --example gyro_bias_drive
//! ```
//!
//! The paper's circle with the gyro (`paper-circle-gyro`, one run, no slip patches, the
//! gyro's scale exact), driven for 600 s after the rest.

use controller_core::prelude::*;
use host_sim::{run_scenario_with, RunOptions};
use robot_files::scenario::Scenario;

fn main() -> anyhow::Result<()> {
    let options = RunOptions::default();
    for rest_s in [5.0, 0.0] {
        let mut scenario = Scenario::load("paper-circle-gyro")?;
        let Some(gyro) = scenario.gyro.as_mut() else {
            anyhow::bail!("paper-circle-gyro has no [gyro] table");
        };
        gyro.sensor.turn_on_bias_rad_s = 0.5_f64.to_radians();
        gyro.rest_before_arming_s = rest_s;
        scenario = scenario.with_duration_s(rest_s + 600.0)?;
        let result = run_scenario_with(&scenario, LawKind::Tracking, options)?;
        let error_deg = result
            .final_heading_estimate_error_rad
            .map_or(f64::NAN, f64::to_degrees);
        println!(
            "turn-on bias 0.5 °/s, {rest_s:.0} s at rest, then 600 s driving: final heading \
             error {error_deg:+.3}°, final true position error {:.3} m",
            result.summary.headline_error().final_position_error_m
        );
    }
    Ok(())
}
