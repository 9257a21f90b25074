//! A simulated run as an MCAP file for Foxglove: its scenario's path and its trace on
//! `robot_foxglove`'s channels, at simulated time, and how the supervisor ended it.

use std::path::Path;

use robot_files::scenario::Scenario;
use robot_foxglove::{McapError, McapWritten, RunRecord};

use crate::run::RunResult;

/// Writes `result` of `scenario` to `file` (replacing it). The trace is the run's own,
/// at the rate it was recorded at; an empty trace writes the path and the end only.
pub fn write_run_mcap(
    file: &Path,
    scenario: &Scenario,
    result: &RunResult,
) -> Result<McapWritten, McapError> {
    let end = end_text(result);
    robot_foxglove::write_run_mcap(
        file,
        &RunRecord {
            path: Some(&scenario.path),
            trace: &result.trace,
            end: Some(&end),
        },
    )
}

/// The run's end as `/events` says it: `run ended after T s: STATE` and the latched
/// faults, if any.
fn end_text(result: &RunResult) -> String {
    let s = &result.summary;
    let mut text = format!(
        "run ended after {:.3} s: {}",
        s.sim_time_s, s.supervisor.final_state
    );
    if !s.supervisor.faults.is_empty() {
        text += &format!(" ({})", s.supervisor.faults.join(", "));
    }
    text
}
