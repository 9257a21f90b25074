//! The virtual robot in Foxglove, live (`host-sim serve --foxglove`): its samples on
//! `robot_foxglove`'s channels at a fixed rate of its control steps (with the truth), its
//! configuration as a parameter set. A change asked while disarmed is sent to the
//! robot's own link side as a `SetParams` (the checks a station's request meets), and the
//! set then shows what the robot runs; while armed the set is read-only.

use controller_core::supervisor::State;
use link::{ParamSet, Request};
use robot_files::robot_file::RobotFile;
use robot_foxglove::live::parameters::apply_changes;
use robot_foxglove::live::{LiveError, LiveServer, ParameterChange, Status};

use super::VirtualRobot;

/// The robot's configuration as a robot file (TOML).
fn robot_file(set: &ParamSet) -> String {
    RobotFile::of(&set.robot, &set.supervisor).to_toml()
}

/// The live stream of one virtual robot.
pub struct LiveStream {
    server: LiveServer,
    every_steps: u32,
    /// Changes taken from the clients, not yet sent to the robot.
    waiting: Vec<ParameterChange>,
    /// A `SetParams` was sent and its reply has not come.
    asked: bool,
}

impl LiveStream {
    /// Starts the server on `address` for `robot`, streaming one sample every
    /// `every_steps` control steps (at least 1).
    pub fn start(
        address: &str,
        robot: &VirtualRobot<'_>,
        every_steps: u32,
    ) -> Result<Self, LiveError> {
        let name = format!("host-sim virtual robot ({})", robot.scenario.name);
        let server = LiveServer::start(address, &name, &robot_file(&robot.active_params()))?;
        Ok(Self {
            server,
            every_steps: every_steps.max(1),
            waiting: Vec::new(),
            asked: false,
        })
    }

    /// The port the server listens on.
    pub fn port(&self) -> u16 {
        self.server.port()
    }

    /// After each control step of `robot`: a sample when one is due, and the parameter
    /// changes the clients asked for.
    pub fn after_step(&mut self, robot: &mut VirtualRobot<'_>) {
        if robot.control.steps().is_multiple_of(self.every_steps) {
            if let Some(row) = robot.trace_row() {
                self.server.log_sample(&row, robot.path());
            }
        }
        self.parameters(robot);
    }

    fn parameters(&mut self, robot: &mut VirtualRobot<'_>) {
        if let Some(reply) = robot.take_local_reply() {
            self.asked = false;
            if let Err(refusal) = reply {
                self.server.publish_status(Status::error(format!(
                    "the robot refused the parameters: {refusal:?}"
                )));
            }
            self.server
                .publish_parameters(&robot_file(&robot.active_params()));
        }
        self.waiting.extend(self.server.take_parameter_changes());
        if self.waiting.is_empty() || self.asked {
            return;
        }
        let armed = robot.last_step.is_some_and(|s| s.out.state == State::Armed);
        if armed {
            self.waiting.clear();
            self.server.publish_status(Status::warning(
                "the parameters are read-only while the robot is armed",
            ));
            return;
        }
        let current = robot.active_params();
        let asked = apply_changes(&robot_file(&current), &self.waiting)
            .map_err(|e| e.to_string())
            .and_then(|text| RobotFile::from_toml(&text).map_err(|e| e.to_string()))
            .and_then(|file| {
                file.over(&current.robot, &current.supervisor)
                    .map_err(|e| e.to_string())
            });
        match asked {
            Ok((robot_config, supervisor)) => {
                let set = ParamSet {
                    robot: robot_config,
                    supervisor,
                };
                if robot.request_locally(Request::SetParams(set)) {
                    self.asked = true;
                    self.waiting.clear();
                }
            }
            Err(e) => {
                self.waiting.clear();
                self.server.publish_status(Status::error(e));
            }
        }
    }
}
