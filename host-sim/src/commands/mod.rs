//! The `host-sim` commands, one module each (the binary only parses the command line and
//! dispatches here).
//!
//! Each command's `run` loads its scenario, does the work, writes its files into its
//! output folder and returns a report: a value whose [`Display`](fmt::Display) is exactly
//! what the command prints on stdout, and whose [`Report::verdict`] says whether the
//! command failed (`host-sim` then prints `error: …` on stderr and exits with 1). Every
//! such rule — a failed case, a failed verdict line, an argument out of its range — is a
//! function of this module's commands, tested here.
//!
//! A command that runs for a long time ([`pil`], [`tune`], [`serve`]) says what it starts
//! before it starts, through a [`Progress`] sink, so the first line is on screen while it
//! runs; [`serve`] also reports every supervisor event through it.

use std::fmt;
use std::path::PathBuf;

use robot_files::scenario::{Scenario, ScenarioError};

pub mod compare;
pub mod faults;
pub mod list;
pub mod margins;
pub mod paper;
pub mod param_sweep;
pub mod pil;
pub mod run;
pub mod serve;
pub mod show;
pub mod step_response;
pub mod sweep;
pub mod tune;
pub mod velocity_check;

/// A command's report: what it prints ([`fmt::Display`], every line ending in a newline)
/// and whether the command failed.
pub trait Report: fmt::Display {
    /// `Err` when the command failed: `host-sim` prints the report, then `error: ` and
    /// the message, and exits with 1. The default: the command never fails once it has a
    /// report.
    fn verdict(&self) -> Result<(), Failed> {
        Ok(())
    }
}

/// Why a command failed or refused an argument: the message `host-sim` prints after
/// `error: `.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct Failed(pub String);

/// Where a long-running command writes the lines it prints while it runs (each value's
/// `Display` ends in a newline). An I/O error (stdout closed) stops the command with
/// that error.
pub type Progress<'a> = dyn FnMut(&dyn fmt::Display) -> std::io::Result<()> + 'a;

/// The scenario `name` (a built-in name or a path to a TOML file); a value error says
/// which file it is in (syntax errors already do).
pub fn load(name: &str) -> anyhow::Result<Scenario> {
    Scenario::load(name).map_err(|e| match e {
        ScenarioError::Invalid { .. } => anyhow::Error::new(e).context(name.to_string()),
        other => other.into(),
    })
}

/// A command's default output folder: `host-sim-out/<scenario>/<leaf>`, relative to the
/// working directory, with every character of the scenario's name other than ASCII
/// letters, digits, `-` and `_` replaced by `_` (a file path as the name would nest
/// oddly).
pub fn default_dir(scenario: &Scenario, leaf: &str) -> PathBuf {
    let name: String = scenario
        .name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    PathBuf::from("host-sim-out").join(name).join(leaf)
}

/// `Some(t)` as milliseconds with `decimals` decimals and ` ms`, `None` as `none`.
pub(crate) fn ms_or(v: Option<f64>, decimals: usize, none: &str) -> String {
    v.map_or(none.to_string(), |t| format!("{:.*} ms", decimals, t * 1e3))
}

/// Creates `dir` (and its parents), saying which folder failed.
pub(crate) fn create_dir(dir: &std::path::Path) -> anyhow::Result<()> {
    use anyhow::Context as _;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_folder_keeps_only_safe_characters_of_the_name() {
        let mut scenario = Scenario::load("paper-circle").expect("built in");
        assert_eq!(
            default_dir(&scenario, "tracking"),
            PathBuf::from("host-sim-out/paper-circle/tracking")
        );
        scenario.name = "my dir/a b.toml".into();
        assert_eq!(
            default_dir(&scenario, "faults"),
            PathBuf::from("host-sim-out/my_dir_a_b_toml/faults")
        );
    }

    #[test]
    fn a_value_error_names_its_file_and_an_unknown_name_is_refused() {
        assert!(load("paper-circle").is_ok());
        let unknown = load("no-such-scenario").expect_err("unknown");
        assert!(unknown.downcast_ref::<ScenarioError>().is_some());
    }
}
