//! Step 1: the link answers; who the robot is, what its clock runs from, its brown-out
//! level, why it last reset and the record of a failure that ended an earlier run (the
//! robot keeps it, across resets, until a host has read it: shown here, then cleared).

use super::{BringupError, Finding, Session};
use crate::ops;
use crate::transport::Transport;

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let info = ops::info(s.client)?;
    let failure = ops::panic_record(s.client)?;
    let link = s.client.transport().describe();
    for line in ops::describe_robot(&info, failure.as_ref(), &link).lines() {
        writeln!(s.out, "  {line}")?;
    }
    if failure.is_some() {
        ops::clear_panic_record(s.client)?;
    }
    if !info.brown_out_reset.guards_flash_writes() {
        return Err(BringupError::Found(format!(
            "the brown-out reset is {}: the robot refuses to persist parameters until it is \
             at level 3, which the firmware sets when it starts (see its log)",
            info.brown_out_reset
        )));
    }
    let mut summary = format!(
        "{} on {}, clock: {}, brown-out reset {}, last reset: {}",
        info.robot_name,
        info.chip,
        info.clock,
        info.brown_out_reset,
        ops::reset_text(info.reset_cause)
    );
    summary.push_str(match failure {
        Some(_) => ", a panic record (shown above, now cleared)",
        None => ", no panic record",
    });
    Ok(Finding::only(summary))
}
