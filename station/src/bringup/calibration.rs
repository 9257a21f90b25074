//! Step 7: the odometry calibration (`station calibrate`'s code: UMBmark squares both
//! ways, then a straight run against a tape). Before each run the user puts the robot at
//! its start and says so; after it, they type the measured end point (or, for the
//! straight run, the tape's distance): asked like every other answer, at the terminal or
//! from `--answers`.

use std::cell::RefCell;

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
    // The questions and the progress lines share the terminal.
    let out = RefCell::new(&mut *s.out);
    let answers = &mut s.answers;
    let mut ask = |question: &str| {
        answers
            .ask(&mut **out.borrow_mut(), question)
            .map_err(|e| e.to_string())
    };
    let mut say = |line: &str| {
        let _ = writeln!(out.borrow_mut(), "  {line}");
    };
    let outcome = calibrate::calibrate(
        s.client,
        &base,
        &args,
        &mut Measure::Asked(&mut ask),
        &mut say,
    )
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
