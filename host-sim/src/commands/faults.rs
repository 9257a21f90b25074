//! `host-sim faults`: every kind of fault, one at a time ([`crate::fault_suite`]), on a
//! scenario: what the supervisor did and how fast, against its detector's limit. A table
//! on stdout, `faults.json` in the output folder; the command fails when a case did not
//! behave as its expectation says ([`verdict`]).

use std::fmt;
use std::path::PathBuf;

use anyhow::{Context, Result};
use controller_core::law::LawKind;

use super::{create_dir, default_dir, load, ms_or, Failed, Report};
use crate::fault_suite::{run_suite, CaseResult, Expectation, INJECT_AT_S};

/// The suite's results and where `faults.json` went.
#[derive(Clone, Debug)]
pub struct FaultsReport {
    /// The scenario's name.
    pub scenario: String,
    /// The steering law.
    pub law: LawKind,
    /// One result per case, in [`crate::fault_suite::cases`] order.
    pub results: Vec<CaseResult>,
    /// `faults.json`.
    pub file: PathBuf,
}

impl fmt::Display for FaultsReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} with the {} law, armed in motion, each fault injected at {INJECT_AT_S} s:\n",
            self.scenario,
            self.law.name()
        )?;
        writeln!(
            f,
            "{:<38} {:>8} {:>9} {:>8} {:>8} {:>9}  by / would be seen by",
            "fault", "detected", "latency", "limit", "after/m", "stopped"
        )?;
        let ms = |v: Option<f64>| ms_or(v, 0, "—");
        for r in &self.results {
            let by = match r.expect {
                Expectation::Undetectable { sensor } => sensor.to_string(),
                Expectation::Warn { .. } => {
                    format!("warned: {}", r.report.warning.as_deref().unwrap_or("—"))
                }
                _ => r.report.detected_by.join(", "),
            };
            let by = match (r.max_gyro_disagreement_radps, r.expect) {
                (_, Expectation::Warn { .. }) | (None, _) => by,
                (Some(d), _) => format!("{by}; mean |gyro − odometry| up to {d:.3} rad/s"),
            };
            let stopped = r.report.wheels_stopped_s.map(|t| t - r.report.injected_s);
            writeln!(
                f,
                "{:<38} {:>8} {:>9} {:>8} {:>8.3} {:>9}  {}{}",
                r.case,
                if r.detected { "yes" } else { "no" },
                ms(r.latency_s),
                ms(r.limit_s),
                r.report.distance_after_m,
                ms(stopped),
                by,
                if r.passed {
                    ""
                } else {
                    "   <-- NOT AS EXPECTED"
                }
            )?;
        }
        writeln!(
            f,
            "\n(latency: from injection to the supervisor stopping the robot, or to its warning for a \
case it drives on through; after/m: true distance \
driven from the injection to the end; stopped: until both wheels turn < 0.1 rad/s)\nwrote {}",
            self.file.display()
        )
    }
}

impl Report for FaultsReport {
    fn verdict(&self) -> Result<(), Failed> {
        verdict(&self.results)
    }
}

/// The rule: every case passed; otherwise `not as expected: ` and the failed cases'
/// names, comma-separated, in suite order.
pub fn verdict(results: &[CaseResult]) -> Result<(), Failed> {
    let failed: Vec<&str> = results
        .iter()
        .filter(|r| !r.passed)
        .map(|r| r.case)
        .collect();
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Failed(format!("not as expected: {}", failed.join(", "))))
    }
}

/// Runs the suite on `scenario` with `law` and writes `faults.json` into `out` (`None`:
/// `host-sim-out/<scenario>/faults`), and each case's run as an MCAP file into `mcap_dir`
/// if given.
pub fn run(
    scenario: &str,
    law: LawKind,
    out: Option<PathBuf>,
    mcap_dir: Option<PathBuf>,
) -> Result<FaultsReport> {
    let scenario = load(scenario)?;
    if let Some(dir) = &mcap_dir {
        create_dir(dir)?;
    }
    let results = run_suite(&scenario, law, mcap_dir.as_deref())?;
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "faults"));
    create_dir(&dir)?;
    let file = dir.join("faults.json");
    let json = serde_json::to_string_pretty(&results).context("serialising the faults")?;
    std::fs::write(&file, json + "\n").with_context(|| format!("writing {}", file.display()))?;
    Ok(FaultsReport {
        scenario: scenario.name,
        law,
        results,
        file,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use robot_files::metrics::FaultReport;

    fn case(name: &'static str, passed: bool) -> CaseResult {
        CaseResult {
            case: name,
            fault: "encoder-disconnect".into(),
            detected: passed,
            latency_s: passed.then_some(0.05),
            limit_s: Some(0.1),
            expect: Expectation::Detect {
                limit_s: 0.1,
                because: "test",
            },
            passed,
            report: FaultReport {
                fault: "encoder-disconnect".into(),
                injected_s: INJECT_AT_S,
                detected: passed,
                detected_s: passed.then_some(INJECT_AT_S + 0.05),
                latency_s: passed.then_some(0.05),
                detected_by: Vec::new(),
                motors_zero_s: None,
                wheels_stopped_s: None,
                distance_after_m: 0.0,
                warning: None,
                warning_latency_s: None,
            },
            final_state: "Faulted".into(),
            final_true_error_m: None,
            max_gyro_disagreement_radps: None,
        }
    }

    #[test]
    fn the_suite_fails_naming_every_case_that_did_not_behave() {
        assert_eq!(verdict(&[case("a", true), case("b", true)]), Ok(()));
        assert_eq!(verdict(&[]), Ok(()));
        assert_eq!(
            verdict(&[case("a", false), case("b", true), case("c", false)]),
            Err(Failed("not as expected: a, c".into()))
        );
    }
}
