//! The live view: the latest telemetry (state, pose, errors, speeds, volts, faults)
//! redrawn in place in a terminal, one screen after the other in a file or a pipe.

use std::fmt::Write as _;

use controller_core::supervisor::State;
use link::{GroundTruth, TelemetryFrame};

/// The screen for `frame` (and the virtual robot's `truth` for the same step, if any),
/// as lines of text, at `rate_hz` control steps per second.
pub fn screen(frame: &TelemetryFrame, truth: Option<&GroundTruth>, rate_hz: u32) -> String {
    let mut s = String::new();
    let t = f64::from(frame.step) / f64::from(rate_hz.max(1));
    let faults = robot_files::metrics::fault_names(&frame.faults);
    let _ = writeln!(
        s,
        "step {:>10}  t {:>9.2} s   state {:?} ({:?})",
        frame.step, t, frame.state, frame.run_mode
    );
    let p = frame.pose;
    let _ = writeln!(
        s,
        "pose (odometry)   x {:+8.3} m   y {:+8.3} m   θ {:+7.2}°",
        p.x_m,
        p.y_m,
        p.theta_rad.to_degrees()
    );
    match truth {
        Some(g) => {
            let _ = writeln!(
                s,
                "pose (true)       x {:+8.3} m   y {:+8.3} m   θ {:+7.2}°",
                g.pose.x_m,
                g.pose.y_m,
                g.pose.theta_rad.to_degrees()
            );
        }
        None => {
            let _ = writeln!(
                s,
                "pose (true)       (a real robot knows only its estimate)"
            );
        }
    }
    let e = frame.tracking_error;
    let _ = writeln!(
        s,
        "error (estimate)  x_e {:+7.4} m   y_e {:+7.4} m   θ_e {:+6.2}°   V {:.4}  V̇ {:+.4}",
        e.x_e_m,
        e.y_e_m,
        e.theta_e_rad.to_degrees(),
        frame.lyapunov,
        frame.lyapunov_rate
    );
    let _ = writeln!(
        s,
        "wheels rad/s      set {:+7.2} / {:+7.2}   measured {:+7.2} / {:+7.2}",
        frame.wheel_setpoint.left_rad_s,
        frame.wheel_setpoint.right_rad_s,
        frame.wheel_speed.left_rad_s,
        frame.wheel_speed.right_rad_s
    );
    let volts = |p: &link::PidParts| p.p_v + p.i_v + p.d_v + p.ff_v;
    if frame.state == State::Armed {
        let _ = writeln!(
            s,
            "motors            {:+6.2} V / {:+6.2} V   duty {:+5.2} / {:+5.2}   supply {:.2} V",
            volts(&frame.pid_left),
            volts(&frame.pid_right),
            frame.duty.left,
            frame.duty.right,
            frame.supply_v
        );
    } else {
        // Not armed, the bridge is off: nothing reaches the motors, whatever the wheel
        // loops would ask.
        let _ = writeln!(
            s,
            "motors            off ({:?})   supply {:.2} V",
            frame.state, frame.supply_v
        );
    }
    let _ = writeln!(
        s,
        "faults            {}   missed ticks {}",
        if faults.is_empty() {
            "none".to_string()
        } else {
            faults.join(", ")
        },
        frame.missed_ticks
    );
    s
}

/// What goes before the next screen when `shown` lines of the last one are on the
/// output: on a terminal, [`redraw_prefix`]; in a file or a pipe no escape code, a blank
/// line between screens.
pub fn separator(shown: usize, terminal: bool) -> String {
    match (terminal, shown) {
        (true, _) => redraw_prefix(shown),
        (false, 0) => String::new(),
        (false, _) => "\n".to_string(),
    }
}

/// Terminal escape: cursor up `lines` lines and clear to the end of the screen, to
/// redraw a screen of `lines` lines in place.
pub fn redraw_prefix(lines: usize) -> String {
    if lines == 0 {
        String::new()
    } else {
        format!("\x1b[{lines}A\x1b[J")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::kinematics::Pose;

    #[test]
    fn the_screen_names_state_pose_and_faults() {
        let mut frame = crate::test_frames::still(2500);
        frame.state = controller_core::supervisor::State::Armed;
        frame.pose = Pose::new(1.0, -0.5, 0.0);
        let text = screen(&frame, None, 1000);
        assert!(text.contains("t      2.50 s"), "{text}");
        assert!(text.contains("x   +1.000 m   y   -0.500 m"), "{text}");
        assert!(text.contains("faults            none"), "{text}");
        frame
            .faults
            .set(controller_core::supervisor::Fault::StallLeft);
        assert!(screen(&frame, None, 1000).contains("stall_left"));
        assert_eq!(redraw_prefix(7), "\x1b[7A\x1b[J");
        assert_eq!(separator(7, true), "\x1b[7A\x1b[J");
        assert_eq!(separator(7, false), "\n");
        assert_eq!(separator(0, false), "");
    }

    #[test]
    fn a_robot_not_armed_shows_its_motors_off() {
        let mut frame = crate::test_frames::still(10);
        // What the wheel loops would ask for (the feed-forward's breakaway).
        frame.pid_left.ff_v = 3.0;
        frame.pid_right.ff_v = 3.32;
        let text = screen(&frame, None, 1000);
        assert!(text.contains("motors            off (Disarmed)"), "{text}");
        assert!(
            !text.contains("3.00 V") && !text.contains("3.32 V"),
            "{text}"
        );
        frame.state = controller_core::supervisor::State::Armed;
        let text = screen(&frame, None, 1000);
        assert!(text.contains("+3.00 V /  +3.32 V"), "{text}");
    }
}
