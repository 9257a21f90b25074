//! The robot live in Foxglove (`station watch --foxglove`): each telemetry frame (with
//! the virtual robot's truth) as a trace row on `robot_foxglove`'s channels, at the
//! robot's own time, and the robot's parameters as a parameter set. A change asked while
//! the robot is disarmed is checked and sent as `params set` would send it; while armed
//! the set is read-only. The robot does not send its path, so none is drawn.

use controller_core::params::Params;
use controller_core::supervisor::State;
use link::{GroundTruth, ParamSet, TelemetryFrame};
use robot_foxglove::live::parameters::apply_changes;
use robot_foxglove::live::{LiveError, LiveServer, Status};

use crate::client::{Client, StationError};
use crate::ops;
use crate::record::trace_row;
use crate::transport::Transport;

/// The live stream of the robot the station is connected to.
pub struct FoxgloveStream {
    server: LiveServer,
    params: ParamSet,
    geometry: Option<Params>,
}

impl FoxgloveStream {
    /// Starts the server on `address` (`HOST:PORT`) with the robot's configuration
    /// `params` as its parameter set.
    pub fn start(address: &str, params: &ParamSet) -> Result<Self, LiveError> {
        Ok(Self {
            server: LiveServer::start(address, "station", &ops::params_to_toml(params))?,
            params: *params,
            geometry: Params::new(params.robot).ok(),
        })
    }

    /// The address clients connect to: `address` with the port the server listens on.
    pub fn address(&self, address: &str) -> String {
        let host = address.rsplit_once(':').map_or(address, |(h, _)| h);
        format!("{host}:{}", self.server.port())
    }

    /// Streams `frame` (and `truth` for the same step), the robot running `rate_hz`
    /// control steps a second.
    pub fn frame(&mut self, frame: &TelemetryFrame, truth: Option<&GroundTruth>, rate_hz: u32) {
        let t_s = f64::from(frame.step) / f64::from(rate_hz.max(1));
        let truth = truth.filter(|t| t.step == frame.step);
        let row = trace_row(frame, truth, t_s, None, self.geometry.as_ref());
        self.server.log_sample(&row, None);
    }

    /// Applies the parameter changes the clients asked for, the robot being in `state`:
    /// refused while armed; otherwise written into the robot's configuration, checked
    /// (an error names the key) and sent; the set then shows what the robot runs. A
    /// refusal is told to the clients; only a failed link is an error.
    pub fn parameters<T: Transport>(
        &mut self,
        client: &mut Client<T>,
        state: State,
    ) -> Result<(), StationError> {
        let changes = self.server.take_parameter_changes();
        if changes.is_empty() {
            return Ok(());
        }
        if state == State::Armed {
            self.server.publish_status(Status::warning(
                "the parameters are read-only while the robot is armed",
            ));
            return Ok(());
        }
        let text = ops::params_to_toml(&self.params);
        let asked = apply_changes(&text, &changes)
            .map_err(|e| e.to_string())
            .and_then(|changed| {
                ops::params_from_toml(&changed, "foxglove", &self.params).map_err(|e| e.to_string())
            });
        let set = match asked {
            Ok(set) => set,
            Err(e) => {
                self.server.publish_status(Status::error(e));
                return Ok(());
            }
        };
        match ops::set_params(client, set) {
            Ok(_) => {}
            Err(StationError::Refused { refusal, .. }) => {
                self.server.publish_status(Status::error(format!(
                    "the robot refused the parameters: {refusal:?}"
                )));
            }
            Err(e) => return Err(e),
        }
        self.params = ops::get_params(client)?;
        self.geometry = Params::new(self.params.robot).ok();
        self.server
            .publish_parameters(&ops::params_to_toml(&self.params));
        Ok(())
    }
}
