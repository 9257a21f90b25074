//! What a bring-up learned, shown as a robot-file diff: the keys whose values change,
//! under their sections, old value `-`, new value `+`.

use link::ParamSet;

use crate::ops::params_to_toml;

/// The keys of a robot file, each with its section: (`[robot.wiring]`, `motors_swapped`,
/// the whole line).
fn keyed_lines(toml: &str) -> Vec<(String, String, String)> {
    let mut section = String::new();
    let mut keys = Vec::new();
    for line in toml.lines() {
        let trimmed = line.trim();
        if trimmed.starts_with('[') {
            section = trimmed.to_string();
        } else if let Some((key, _)) = trimmed.split_once('=') {
            if !trimmed.starts_with('#') {
                keys.push((section.clone(), key.trim().to_string(), trimmed.to_string()));
            }
        }
    }
    keys
}

/// The robot-file diff from `before` to `after`; empty when nothing changes.
pub fn robot_file_diff(before: &ParamSet, after: &ParamSet) -> String {
    let old = keyed_lines(&params_to_toml(before));
    let new = keyed_lines(&params_to_toml(after));
    let mut out = String::new();
    let mut shown_section = String::new();
    for (section, key, line) in &new {
        let was = old
            .iter()
            .find(|(s, k, _)| s == section && k == key)
            .map(|(_, _, l)| l.as_str());
        if was == Some(line.as_str()) {
            continue;
        }
        if *section != shown_section {
            out.push_str(&format!("  {section}\n"));
            shown_section.clone_from(section);
        }
        if let Some(was) = was {
            out.push_str(&format!("- {was}\n"));
        }
        out.push_str(&format!("+ {line}\n"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::params::RobotConfig;
    use controller_core::supervisor::SupervisorConfig;

    #[test]
    fn only_the_changed_keys_show_under_their_section() {
        let robot = RobotConfig::REFERENCE_ROBOT;
        let before = ParamSet {
            robot,
            supervisor: SupervisorConfig::at_rate(
                1000,
                controller_core::kinematics::Pose::default(),
                controller_core::kinematics::WheelSpeeds::new(5.0, 5.0),
            ),
        };
        assert_eq!(robot_file_diff(&before, &before), "");
        let mut after = before;
        after.robot.wiring.motors_swapped = true;
        after.robot.encoder_lines_per_motor_rev = 24;
        let diff = robot_file_diff(&before, &after);
        assert_eq!(
            diff,
            "  [robot]\n- encoder_lines_per_motor_rev = 12\n+ encoder_lines_per_motor_rev = 24\n  \
             [robot.wiring]\n- motors_swapped = false\n+ motors_swapped = true\n"
        );
    }
}
