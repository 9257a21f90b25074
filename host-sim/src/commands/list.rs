//! `host-sim list`: the built-in scenarios, one a line: the name and its description.

use std::fmt;

use robot_files::scenario::{Scenario, BUILTIN};

use super::Report;

/// Every built-in scenario's name and description (empty if it does not parse).
#[derive(Clone, Debug, PartialEq)]
pub struct ListReport {
    /// (name, description), in [`BUILTIN`] order.
    pub scenarios: Vec<(&'static str, String)>,
}

impl fmt::Display for ListReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (name, description) in &self.scenarios {
            writeln!(f, "{name:<18} {description}")?;
        }
        Ok(())
    }
}

impl Report for ListReport {}

/// The built-in scenarios.
pub fn run() -> ListReport {
    ListReport {
        scenarios: BUILTIN
            .iter()
            .map(|(name, text)| {
                let description = Scenario::from_toml(text, name)
                    .map(|s| s.description)
                    .unwrap_or_default();
                (*name, description)
            })
            .collect(),
    }
}
