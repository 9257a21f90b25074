//! What the bridge does with what ROS 2 sends it: `cmd_vel` forwarded, a path simplified
//! and followed, a pose reset, a parameter written to the robot.

use controller_core::kinematics::Pose;
use link::RunReport;
use ros2_client::ParameterValue;

use super::{Activity, Bridge, PATH_SETTLE_S};
use crate::ros2::connection::PathRun;
use crate::ros2::messages::{Path as PathMessage, PoseWithCovarianceStamped, Twist};
use crate::ros2::odometry::WheelAngles;
use crate::ros2::parameters::{robot_values, with_robot_parameter};
use crate::ros2::path_simplify::simplify;

impl Bridge {
    pub(super) fn commands(&mut self) {
        let commands = self.node.topics.cmd_vel.take_all();
        let Some(last) = commands.last().copied() else {
            return;
        };
        if self.activity != Activity::Velocity {
            let why = format!(
                "cmd_vel not forwarded: the bridge is {}{}",
                self.activity.describe(),
                if self.options.arm {
                    ""
                } else {
                    " (start it with --arm to drive by cmd_vel)"
                }
            );
            if self.status.last_refusal.as_deref() != Some(why.as_str()) {
                self.refuse(why);
            }
            return;
        }
        // Only the newest matters: each command replaces the last on the robot.
        let Twist { linear, angular } = last;
        let sent = self.with_robot(|r| r.velocity(linear.x as f32, angular.z as f32));
        if let Some(Ok(())) = sent {
            self.counts.cmd_vel_forwarded += commands.len() as u64;
        }
    }

    pub(super) fn paths(&mut self) {
        let mut newest: Option<PathMessage> = None;
        while let Ok(Some((path, _))) = self.node.topics.path.take() {
            newest = Some(path);
        }
        if let Some(path) = newest {
            self.follow(&path);
        }
    }

    fn follow(&mut self, message: &PathMessage) {
        let frame = &message.header.frame_id;
        if !(frame.is_empty() || *frame == self.settings.frames.odom_frame_id) {
            self.refuse(format!(
                "path refused: its frame is `{frame}`, the robot's odometry is `{}`",
                self.settings.frames.odom_frame_id
            ));
            return;
        }
        let positions: Vec<(f64, f64)> = message
            .poses
            .iter()
            .map(|p| (p.pose.position.x, p.pose.position.y))
            .collect();
        let simplified = match simplify(
            &positions,
            self.settings.path_tolerance_m,
            self.settings.path_corner_radius_m,
        ) {
            Ok(s) => s,
            Err(e) => {
                self.refuse(format!("path of {} poses refused: {e}", positions.len()));
                return;
            }
        };
        let Some(start) = self.status.latest.map(|f| f.pose) else {
            self.refuse("path refused: no telemetry from the robot yet".into());
            return;
        };
        if !self.disarm() {
            return;
        }
        let speed = self.settings.path_speed_m_s;
        let seconds = f64::from(simplified.path.length_m()) / speed + PATH_SETTLE_S;
        let rate = self
            .robot
            .as_ref()
            .map_or(1000, |r| r.params.robot.control_rate_hz);
        let run = PathRun {
            speed_m_s: speed as f32,
            time_limit_steps: (seconds * f64::from(rate)).min(f64::from(u32::MAX)) as u32,
        };
        match self.with_robot(|r| r.follow_path(&simplified.path, start, run)) {
            Some(Ok(summary)) => {
                println!(
                    "ros2 bridge: path of {} poses as {} waypoints (within {:.3} m, fillets \
                     {:.3} m): {} segments, {:.3} m, followed at {speed} m/s for {seconds:.1} s",
                    positions.len(),
                    simplified.waypoints.len(),
                    simplified.deviation_m,
                    simplified.corner_radius_m,
                    summary.segment_count,
                    summary.length_m,
                );
                self.set_activity(Activity::FollowingPath);
                self.publish_diagnostics();
            }
            Some(Err(e)) => {
                self.refuse(format!(
                    "path refused by the robot: {}",
                    crate::error_text(&e)
                ));
                self.resume();
            }
            None => {}
        }
    }

    pub(super) fn path_ended(&mut self, report: &RunReport) {
        self.counts.paths_followed += 1;
        let e = &report.estimated;
        let settled = e.settle_time_s.map_or("did not settle".to_string(), |t| {
            format!("settled at {t:.2} s")
        });
        let line = format!(
            "path run ended after {:.2} s: {settled}, final error {:.4} m, RMS {:.4} m",
            f64::from(report.run_steps)
                / f64::from(
                    self.robot
                        .as_ref()
                        .map_or(1000, |r| r.params.robot.control_rate_hz)
                ),
            e.final_position_error_m,
            e.rms_position_error_m,
        );
        println!("ros2 bridge: {line}");
        self.status.activity = line;
        self.publish_diagnostics();
        self.resume();
    }

    pub(super) fn pose_resets(&mut self) {
        let mut newest: Option<PoseWithCovarianceStamped> = None;
        while let Ok(Some((pose, _))) = self.node.topics.set_pose.take() {
            newest = Some(pose);
        }
        let Some(message) = newest else {
            return;
        };
        let p = message.pose.pose;
        let pose = Pose::new(
            p.position.x as f32,
            p.position.y as f32,
            p.orientation.yaw_rad() as f32,
        );
        if self.robot.is_none() {
            self.refuse("set_pose refused: the link to the robot is down".into());
            return;
        }
        let was = self.activity;
        if was == Activity::FollowingPath {
            self.refuse("set_pose refused: a path is being followed".into());
            return;
        }
        if !self.disarm() {
            return;
        }
        match self.with_robot(|r| r.set_pose(pose)) {
            Some(Ok(())) => {
                println!(
                    "ros2 bridge: pose set to x {:.3} m, y {:.3} m, θ {:.3} rad",
                    pose.x_m, pose.y_m, pose.theta_rad
                );
                self.angles = WheelAngles::default();
            }
            Some(Err(e)) => self.refuse(format!("set_pose refused: {}", crate::error_text(&e))),
            None => return,
        }
        if was == Activity::Velocity {
            self.resume();
        }
    }

    pub(super) fn parameter_changes(&mut self) {
        while let Ok(change) = self.node.changes.try_recv() {
            let (name, value) = (change.name.as_str(), &change.value);
            match self.settings.set(name, value, false) {
                Ok(true) => {
                    if name == "publish_rate" {
                        let hz = self.settings.telemetry_rate_hz();
                        if let Some(Err(e)) = self.with_robot(|r| r.set_telemetry_rate(hz)) {
                            self.refuse(format!("publish_rate: {}", crate::error_text(&e)));
                        }
                    }
                    continue;
                }
                Ok(false) => {}
                Err(e) => {
                    self.refuse(e.to_string());
                    continue;
                }
            }
            self.write_robot_parameter(name, value);
        }
    }

    fn write_robot_parameter(&mut self, name: &str, value: &ParameterValue) {
        let (Some(robot), Some(multipliers)) = (self.robot.as_ref(), self.multipliers) else {
            return;
        };
        let current = robot.params;
        let (set, new_multipliers) = match with_robot_parameter(&current, &multipliers, name, value)
        {
            Ok(Some(change)) => change,
            Ok(None) => return,
            Err(e) => {
                self.refuse(e.to_string());
                return;
            }
        };
        self.multipliers = Some(new_multipliers);
        if set != current {
            let was = self.activity;
            if was == Activity::FollowingPath {
                self.refuse(format!("{name} not written: a path is being followed"));
            } else if self.disarm() {
                match self.with_robot(|r| r.set_params(set)) {
                    Some(Ok(())) => println!("ros2 bridge: {name} written to the robot"),
                    Some(Err(e)) => self.refuse(format!(
                        "{name} refused by the robot: {}",
                        crate::error_text(&e)
                    )),
                    None => return,
                }
                if was == Activity::Velocity {
                    self.resume();
                }
            }
        }
        // The node shows what the robot holds, whatever happened.
        if let (Some(robot), Some(m)) = (self.robot.as_ref(), self.multipliers) {
            let values = robot_values(&robot.params, &m);
            self.show_robot_values(values);
        }
    }
}
