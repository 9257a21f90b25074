//! `[velocity]`: a run in the velocity mode, its commands a timeline of (t, v, ω).
//!
//! ```toml
//! [velocity]
//! commands = [[0.5, 0.3, 0.0], [2.5, 0.3, 1.5], [4.5, -0.2, 0.0]]  # [t_s, v_m_s, omega_rad_s]
//! command_period_s = 0.05   # a command every this long from each entry on (default 0.05)
//! stop_sending_s = 6.5      # no command from then on: the timeout stops the robot (default: never)
//! ```
//!
//! A scenario with this section arms in the velocity mode at step 0 instead of path
//! following. Each entry's command is sent at its time and then streamed every
//! `command_period_s`, as a host streams `cmd_vel`, until the next entry or
//! `stop_sending_s`. Times are rounded to control steps.

use controller_core::kinematics::BodyVelocity;

use super::checks::{check, finite, non_negative, positive};
use super::raw_value::{array, numbers};
use super::schema::FileVelocity;
use super::ScenarioError;

/// One entry of the timeline: from `at_step` on, `command` is streamed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityEntry {
    /// Control step of the entry (its time × the control rate, rounded).
    pub at_step: u64,
    /// The command (v m/s, ω rad/s, robot frame).
    pub command: BodyVelocity,
}

/// The velocity commands of a run (module doc), in control steps.
#[derive(Clone, Debug, PartialEq)]
pub struct VelocityTimeline {
    /// The entries, in time order.
    pub entries: Vec<VelocityEntry>,
    /// Steps between two commands of one entry (≥ 1).
    pub command_period_steps: u64,
    /// No command is sent from this step on (`None`: to the end of the run).
    pub stop_sending_step: Option<u64>,
}

impl VelocityTimeline {
    /// The command sent at control step `step`, if one is: the latest entry's, at its
    /// own step and every `command_period_steps` after it, before `stop_sending_step`.
    pub fn sent_at(&self, step: u64) -> Option<BodyVelocity> {
        if self.stop_sending_step.is_some_and(|stop| step >= stop) {
            return None;
        }
        let entry = self.entries.iter().rev().find(|e| e.at_step <= step)?;
        ((step - entry.at_step) % self.command_period_steps == 0).then_some(entry.command)
    }

    /// The step of the last command sent before `end` (a step count), if any.
    pub fn last_sent_before(&self, end: u64) -> Option<u64> {
        let end = self.stop_sending_step.map_or(end, |stop| stop.min(end));
        let entry = self.entries.iter().rev().find(|e| e.at_step < end)?;
        let periods = (end - 1 - entry.at_step) / self.command_period_steps;
        Some(entry.at_step + periods * self.command_period_steps)
    }
}

/// The timeline `[velocity]` describes at a control rate of `control_hz` (Hz).
pub(super) fn build(
    file: &FileVelocity,
    control_hz: u32,
) -> Result<VelocityTimeline, ScenarioError> {
    let rate = f64::from(control_hz);
    let to_step = |s: f64| (s * rate).round() as u64;
    let items = array(
        "velocity.commands",
        &file.commands,
        "[t_s, v_m_s, omega_rad_s] entries",
    )?;
    check(
        !items.is_empty(),
        "velocity.commands",
        "must hold at least one entry",
        0.0,
    )?;
    let mut entries: Vec<VelocityEntry> = Vec::with_capacity(items.len());
    for (i, item) in items.iter().enumerate() {
        let key = format!("velocity.commands[{i}]");
        let [t, v, w] = numbers::<3>(&key, item)?;
        non_negative(&format!("{key}[0]"), t)?;
        finite(&format!("{key}[1]"), v)?;
        finite(&format!("{key}[2]"), w)?;
        let at_step = to_step(t);
        if let Some(last) = entries.last() {
            check(
                at_step > last.at_step,
                &format!("{key}[0]"),
                "must be later than the entry before it (by a control step at least)",
                t,
            )?;
        }
        entries.push(VelocityEntry {
            at_step,
            command: BodyVelocity::new(v as f32, w as f32),
        });
    }
    let period_s = positive(
        "velocity.command_period_s",
        file.command_period_s.unwrap_or(0.05),
    )?;
    let command_period_steps = to_step(period_s).max(1);
    let stop_sending_step = match file.stop_sending_s {
        Some(s) => Some(to_step(non_negative("velocity.stop_sending_s", s)?)),
        None => None,
    };
    Ok(VelocityTimeline {
        entries,
        command_period_steps,
        stop_sending_step,
    })
}

#[cfg(test)]
mod tests {
    use super::super::Scenario;

    fn with_velocity(section: &str) -> Result<Scenario, String> {
        let base = super::super::BUILTIN
            .iter()
            .find(|(n, _)| *n == "paper-line")
            .map(|(_, t)| *t)
            .unwrap_or_default();
        Scenario::from_toml(&format!("{base}\n[velocity]\n{section}\n"), "t")
            .map_err(|e| e.to_string())
    }

    #[test]
    fn the_timeline_streams_each_entry_until_the_silence() {
        let s =
            with_velocity("commands = [[0.5, 0.3, 0.0], [1.0, 0.0, 1.0]]\nstop_sending_s = 1.2")
                .expect("valid");
        let t = s.velocity.expect("a timeline");
        assert_eq!(t.command_period_steps, 50);
        assert_eq!(t.sent_at(499), None, "nothing before the first entry");
        assert_eq!(t.sent_at(500).map(|c| c.v_m_s), Some(0.3));
        assert_eq!(t.sent_at(501), None);
        assert_eq!(t.sent_at(950).map(|c| c.v_m_s), Some(0.3));
        assert_eq!(t.sent_at(1000).map(|c| c.omega_rad_s), Some(1.0));
        assert_eq!(t.sent_at(1200), None, "silence from stop_sending_s");
        assert_eq!(t.last_sent_before(8000), Some(1150));
    }

    #[test]
    fn a_bad_entry_is_named() {
        let e = with_velocity("commands = [[0.5, 0.3]]").unwrap_err();
        assert!(e.contains("velocity.commands[0]"), "{e}");
        let e = with_velocity("commands = [[1.0, 0.3, 0.0], [0.5, 0.0, 0.0]]").unwrap_err();
        assert!(
            e.contains("velocity.commands[1][0]") && e.contains("later"),
            "{e}"
        );
        let e = with_velocity("commands = [[0.0, 0.3, 0.0]]\ncommand_period_s = 0").unwrap_err();
        assert!(e.contains("velocity.command_period_s"), "{e}");
        let e = with_velocity("commands = []").unwrap_err();
        assert!(e.contains("velocity.commands"), "{e}");
    }
}
