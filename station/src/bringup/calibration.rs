//! Step 7: the odometry calibration (`station calibrate`'s code: UMBmark squares both
//! ways, then a straight run against a tape). The measured end points are the user's:
//! typed at the terminal, or, with `--answers`, the answers file's remaining lines, one
//! per run as `station calibrate --measurements` reads them.

use robot_files::scenario::Scenario;

use super::{BringupError, Finding, Session};
use crate::calibrate::{self, CalibrateArgs, Measure};
use crate::ops;
use crate::transport::Transport;

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let before = ops::get_params(s.client)?;
    let base = Scenario::load("square-waypoints")
        .map_err(|e| BringupError::Found(format!("the calibration's squares: {e}")))?;
    let args = CalibrateArgs {
        side_m: 2.0,
        runs: 5,
        straight_m: 2.0,
        measurements: None,
        simulated_noise_m: None,
        no_persist: true,
    };
    let mut measure = match s.answers.remaining_lines()? {
        Some(lines) => Measure::File(lines.into_iter()),
        None => Measure::Ask,
    };
    let out = &mut *s.out;
    let mut say = |line: &str| {
        let _ = writeln!(out, "  {line}");
    };
    let outcome = calibrate::calibrate(s.client, &base, &args, &mut measure, &mut say)
        .map_err(|e| BringupError::Found(e.to_string()))?;
    for line in calibrate::table(&outcome).lines() {
        writeln!(s.out, "  {line}")?;
    }
    // Sent by the calibration; given back, so that the bring-up shows and persists it.
    ops::set_params(s.client, before)?;
    Ok(Finding {
        summary: format!("odometry calibrated (scale {:.5})", outcome.scale),
        learned: Some(outcome.after),
    })
}
