//! `station drive`'s keyboard teleop, without the terminal: which key does what to the
//! body-velocity command, and when the next command and heartbeat are due.
//!
//! | key | command |
//! |---|---|
//! | ↑ or `w` | forward speed + [`LINEAR_STEP_M_S`] |
//! | ↓ or `s` | forward speed − [`LINEAR_STEP_M_S`] |
//! | ← or `a` | yaw rate + [`ANGULAR_STEP_RAD_S`] (turn left, counter-clockwise) |
//! | → or `d` | yaw rate − [`ANGULAR_STEP_RAD_S`] (turn right) |
//! | space | stop: both to zero |
//! | `q`, Esc or Ctrl-C | stop, disarm and quit |
//!
//! The command is held within the robot's own velocity limits (`RobotConfig::velocity`),
//! and streamed every [`COMMAND_PERIOD`] whether a key was pressed or not: the robot's
//! command timeout stops it within 0.5 s of the last one if the station goes away.

use std::time::Duration;

use controller_core::kinematics::BodyVelocity;
use controller_core::velocity::VelocityModeConfig;

/// Change of the forward speed per key press, m/s.
pub const LINEAR_STEP_M_S: f32 = 0.05;
/// Change of the yaw rate per key press, rad/s.
pub const ANGULAR_STEP_RAD_S: f32 = 0.25;
/// How often the command is sent, as ROS 2 teleop publishes `cmd_vel` (20 Hz).
pub const COMMAND_PERIOD: Duration = Duration::from_millis(50);

/// A key that means something to the teleop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TeleopKey {
    /// ↑ or `w`.
    Faster,
    /// ↓ or `s`.
    Slower,
    /// ← or `a`.
    Left,
    /// → or `d`.
    Right,
    /// Space.
    Stop,
    /// `q`, Esc or Ctrl-C.
    Quit,
}

impl TeleopKey {
    /// The teleop key of a character typed (`None`: not one).
    pub fn of_char(c: char) -> Option<Self> {
        match c.to_ascii_lowercase() {
            'w' => Some(Self::Faster),
            's' => Some(Self::Slower),
            'a' => Some(Self::Left),
            'd' => Some(Self::Right),
            ' ' => Some(Self::Stop),
            'q' => Some(Self::Quit),
            _ => None,
        }
    }
}

/// The command the keys have set so far, within the robot's limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Teleop {
    max_v_m_s: f32,
    max_omega_rad_s: f32,
    command: BodyVelocity,
}

impl Teleop {
    /// At rest, within the limits of `config` (the robot's velocity mode).
    pub fn new(config: &VelocityModeConfig) -> Self {
        Self {
            max_v_m_s: config.linear_x.max_velocity,
            max_omega_rad_s: config.angular_z.max_velocity,
            command: BodyVelocity::new(0.0, 0.0),
        }
    }

    /// The command to stream (v m/s, ω rad/s, robot frame).
    pub const fn command(&self) -> BodyVelocity {
        self.command
    }

    /// Applies `key`; false when it asks to quit (the command is then zero).
    pub fn press(&mut self, key: TeleopKey) -> bool {
        let c = &mut self.command;
        let step = |x: f32, by: f32, max: f32| {
            // Rounded to the step, so that pressing back and forth comes back to 0 exactly.
            let n = ((x + by) / by.abs()).round();
            (n * by.abs()).clamp(-max, max)
        };
        match key {
            TeleopKey::Faster => c.v_m_s = step(c.v_m_s, LINEAR_STEP_M_S, self.max_v_m_s),
            TeleopKey::Slower => c.v_m_s = step(c.v_m_s, -LINEAR_STEP_M_S, self.max_v_m_s),
            TeleopKey::Left => {
                c.omega_rad_s = step(c.omega_rad_s, ANGULAR_STEP_RAD_S, self.max_omega_rad_s);
            }
            TeleopKey::Right => {
                c.omega_rad_s = step(c.omega_rad_s, -ANGULAR_STEP_RAD_S, self.max_omega_rad_s);
            }
            TeleopKey::Stop => *c = BodyVelocity::new(0.0, 0.0),
            TeleopKey::Quit => {
                *c = BodyVelocity::new(0.0, 0.0);
                return false;
            }
        }
        true
    }

    /// The status line: the command and the keys.
    pub fn status(&self) -> String {
        format!(
            "v {:+.2} m/s  ω {:+.2} rad/s   ↑↓/ws speed, ←→/ad turn, space stop, q quit",
            self.command.v_m_s, self.command.omega_rad_s
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn teleop() -> Teleop {
        Teleop::new(&VelocityModeConfig::at_rate(1000))
    }

    #[test]
    fn keys_step_the_command_with_the_right_signs() {
        let mut t = teleop();
        assert!(t.press(TeleopKey::Faster));
        assert!(t.press(TeleopKey::Faster));
        assert!(t.press(TeleopKey::Left));
        assert_eq!(t.command(), BodyVelocity::new(0.1, 0.25));
        t.press(TeleopKey::Right);
        t.press(TeleopKey::Right);
        assert_eq!(t.command().omega_rad_s, -0.25, "right is clockwise");
        t.press(TeleopKey::Slower);
        t.press(TeleopKey::Slower);
        t.press(TeleopKey::Slower);
        assert!((t.command().v_m_s + 0.05).abs() < 1e-6, "backwards");
        assert!(t.press(TeleopKey::Stop));
        assert_eq!(t.command(), BodyVelocity::new(0.0, 0.0));
    }

    #[test]
    fn the_command_stays_within_the_robot_limits() {
        let mut t = teleop();
        for _ in 0..100 {
            t.press(TeleopKey::Faster);
            t.press(TeleopKey::Left);
        }
        assert_eq!(t.command(), BodyVelocity::new(0.6, 4.0));
    }

    #[test]
    fn quit_stops_and_says_so() {
        let mut t = teleop();
        t.press(TeleopKey::Faster);
        assert!(!t.press(TeleopKey::Quit));
        assert_eq!(t.command(), BodyVelocity::new(0.0, 0.0));
    }

    #[test]
    fn wasd_space_and_q_are_keys() {
        assert_eq!(TeleopKey::of_char('W'), Some(TeleopKey::Faster));
        assert_eq!(TeleopKey::of_char('s'), Some(TeleopKey::Slower));
        assert_eq!(TeleopKey::of_char('a'), Some(TeleopKey::Left));
        assert_eq!(TeleopKey::of_char('d'), Some(TeleopKey::Right));
        assert_eq!(TeleopKey::of_char(' '), Some(TeleopKey::Stop));
        assert_eq!(TeleopKey::of_char('q'), Some(TeleopKey::Quit));
        assert_eq!(TeleopKey::of_char('x'), None);
    }
}
