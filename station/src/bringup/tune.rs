//! Step 6: the wheel-loop self-tune, on the ground (`station tune`'s code): the robot
//! drives about a metre forward and back open loop, identifies each wheel and computes
//! its loop; the loops are what this step learns.

use std::time::Duration;

use super::{BringupError, Finding, Session};
use crate::ops;
use crate::transport::Transport;

/// The longest a tune may take, host time.
const TUNE_LIMIT: Duration = Duration::from_secs(60);

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let current = ops::get_params(s.client)?;
    s.answers.until_done(
        s.out,
        "put the robot on the floor with about a metre free ahead of it and behind it",
    )?;
    let run = ops::tune(
        s.client,
        current.supervisor.heartbeat_timeout_steps,
        TUNE_LIMIT,
    )?;
    let report = run.finished().map_err(BringupError::Found)?;
    for line in ops::describe_tune(&report).lines() {
        writeln!(s.out, "  {line}")?;
    }
    let result = report
        .outcome
        .map_err(|why| BringupError::Found(format!("the tune stopped: {why}")))?;
    let mut learned = current;
    learned.robot = result.apply_to(&current.robot);
    Ok(Finding {
        summary: "the wheel loops are tuned".into(),
        learned: Some(learned),
    })
}
