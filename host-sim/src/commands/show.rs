//! `host-sim show`: a built-in scenario's TOML, as a starting point for one's own.

use std::fmt;

use robot_files::scenario::{ScenarioError, BUILTIN};

use super::Report;

/// A built-in scenario's TOML text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShowReport {
    /// The TOML, printed without its trailing blank lines.
    pub text: &'static str,
}

impl fmt::Display for ShowReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}", self.text.trim_end())
    }
}

impl Report for ShowReport {}

/// The built-in scenario `name`; [`ScenarioError::Unknown`] when there is none of that
/// name (a path to a file is not shown).
pub fn run(name: &str) -> Result<ShowReport, ScenarioError> {
    BUILTIN
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, text)| ShowReport { text })
        .ok_or_else(|| ScenarioError::Unknown(name.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_built_in_name_is_shown() {
        let shown = run("paper-circle").expect("built in");
        assert!(shown.to_string().contains("name = \"paper-circle\""));
        assert!(matches!(
            run("no-such-scenario"),
            Err(ScenarioError::Unknown(name)) if name == "no-such-scenario"
        ));
    }
}
