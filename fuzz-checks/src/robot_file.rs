//! Robot files (`[robot]` and `[supervisor]`, what the station's `params set` reads) on
//! any text ([`check`]).

use controller_core::params::{Params, RobotConfig};
use controller_core::supervisor::SupervisorConfig;
use robot_files::robot_file::{RobotFile, SectionError};

use crate::numbers::assert_all_finite;

/// Reads `input` as a robot file over the reference robot, as `params set` does (input
/// that is not UTF-8 is no text file); panics naming the broken property.
pub fn check(input: &[u8]) {
    let Ok(text) = std::str::from_utf8(input) else {
        return;
    };
    let file = match RobotFile::from_toml(text) {
        Ok(file) => file,
        Err(e) => return assert_names_key(&e, "file"),
    };
    let Some((params, supervisor)) = configuration(&file) else {
        return;
    };
    assert_all_finite(
        "a robot file's configuration",
        &(params.config(), &supervisor),
    );
    if let Err(e) = supervisor.validate(&params) {
        panic!("a robot file's supervisor settings are valid, yet: {e}");
    }
    assert_reads_back(params.config(), &supervisor);
}

/// The validated configuration `file` gives over the reference robot, or `None` when it
/// is refused (the refusal checked to name a key of its section).
fn configuration(file: &RobotFile) -> Option<(Params, SupervisorConfig)> {
    let params = match file.robot.params(RobotConfig::REFERENCE_ROBOT, "robot") {
        Ok(params) => params,
        Err(e) => {
            assert_names_key(&e, "robot.");
            return None;
        }
    };
    match file.supervisor.config(&params, None, "supervisor") {
        Ok(supervisor) => Some((params, supervisor)),
        Err(e) => {
            assert_names_key(&e, "supervisor.");
            None
        }
    }
}

/// A configuration written as a robot file (`params get`) reads back to itself
/// (`params set`), bit for bit.
fn assert_reads_back(robot: &RobotConfig, supervisor: &SupervisorConfig) {
    let written = RobotFile::of(robot, supervisor).to_toml();
    let back = RobotFile::from_toml(&written)
        .unwrap_or_else(|e| panic!("a written robot file reads back ({e}):\n{written}"));
    let (params, supervisor_back) =
        configuration(&back).unwrap_or_else(|| panic!("a written robot file is valid:\n{written}"));
    assert_eq!(
        postcard::to_allocvec(params.config()).ok(),
        postcard::to_allocvec(robot).ok(),
        "[robot] reads back as written:\n{written}"
    );
    assert_eq!(
        postcard::to_allocvec(&supervisor_back).ok(),
        postcard::to_allocvec(supervisor).ok(),
        "[supervisor] reads back as written:\n{written}"
    );
}

/// A refusal names a key starting with `prefix` and says what is wrong.
fn assert_names_key(e: &SectionError, prefix: &str) {
    assert!(
        e.key.starts_with(prefix) && !e.problem.trim().is_empty(),
        "an error names a key under `{prefix}` and the problem: {e:?}"
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seeds;

    #[test]
    fn the_reference_robot_reads_back() {
        for text in seeds::robot_files() {
            check(text.as_bytes());
        }
    }

    #[test]
    fn a_refusal_names_its_key() {
        let e = RobotFile::from_toml("[robot]\ntrack_width_m = \"wide\"\n").unwrap_err();
        assert_eq!(e.key, "file");
        check(b"[robot.motor]\nmax_current_a = -1.0\n");
    }
}
