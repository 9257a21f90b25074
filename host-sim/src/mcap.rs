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

/// `name` as a file stem: every character other than ASCII letters, digits, `-` and `_`
/// replaced by `_` (a case named `encoder disconnected` is `encoder_disconnected`).
pub fn file_stem(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_case_name_becomes_a_safe_file_stem() {
        assert_eq!(file_stem("encoder disconnected"), "encoder_disconnected");
        assert_eq!(file_stem("a/b: c-d_e"), "a_b__c-d_e");
    }
}
