//! Where a bring-up stands, kept in its output directory (`bringup-state.json`), so that
//! one that stopped (a wrong answer, a fault, Ctrl-C) resumes at the step it left.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{BringupError, Step};

/// The state file's name in the output directory.
pub const STATE_FILE: &str = "bringup-state.json";

/// The steps done, and what each found.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct State {
    /// Each step done, in the order done, with what it found (one line).
    pub done: Vec<(Step, String)>,
}

impl State {
    /// The state in `dir`, or a fresh one when it has none.
    pub fn load(dir: &Path) -> Result<Self, BringupError> {
        let path = dir.join(STATE_FILE);
        match std::fs::read_to_string(&path) {
            Ok(text) => serde_json::from_str(&text).map_err(|e| {
                BringupError::Answers(format!("{}: not a bring-up state: {e}", path.display()))
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Self::default()),
            Err(e) => Err(e.into()),
        }
    }

    /// Writes the state into `dir` (created if need be); returns the file's path.
    pub fn save(&self, dir: &Path) -> Result<PathBuf, BringupError> {
        std::fs::create_dir_all(dir)?;
        let path = dir.join(STATE_FILE);
        let text = serde_json::to_string_pretty(self)
            .map_err(|e| BringupError::Answers(format!("cannot write the state: {e}")))?;
        std::fs::write(&path, text + "\n")?;
        Ok(path)
    }

    /// True when `step` was done.
    pub fn has(&self, step: Step) -> bool {
        self.done.iter().any(|(s, _)| *s == step)
    }

    /// Records `step` as done with `found`, replacing an earlier record of it.
    pub fn record(&mut self, step: Step, found: String) {
        self.done.retain(|(s, _)| *s != step);
        self.done.push((step, found));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_state_survives_a_round_trip_and_a_redone_step_replaces_its_record() {
        let dir = std::env::temp_dir().join(format!("bringup-state-{}", std::process::id()));
        let mut state = State::default();
        state.record(Step::Supply, "scale 1.0".into());
        state.record(Step::Encoders, "as labelled".into());
        state.record(Step::Supply, "scale 0.909".into());
        state.save(&dir).expect("written");
        let back = State::load(&dir).expect("read");
        assert_eq!(back, state);
        assert!(back.has(Step::Encoders) && !back.has(Step::Motors));
        assert_eq!(back.done[1], (Step::Supply, "scale 0.909".into()));
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(State::load(&dir).expect("none"), State::default());
    }
}
