//! The live robot over Foxglove's WebSocket protocol (the SDK's server, subprotocol
//! `foxglove.sdk.v1`): the same channels as a file ([`RobotChannels`]) on a context of
//! its own, and the robot's parameters as a parameter set ([`parameters`]), read-only
//! while the robot is armed.

use std::sync::Arc;

use controller_core::path::Path;
use foxglove::websocket::Capability;
use foxglove::{Context, WebSocketServer, WebSocketServerHandle};
use robot_files::trace::TraceRow;

use crate::channels::RobotChannels;

pub mod parameters;

pub use self::parameters::{ParameterChange, RobotParameters};
/// A status message to the clients (level and text).
pub use foxglove::websocket::Status;

/// Where the live server listens unless told otherwise (Foxglove's own default).
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:8765";

/// The path is logged again this often (s of the run), so a client that joins late
/// draws it.
const PATH_EVERY_S: f64 = 2.0;

/// Why the live server could not start.
#[derive(Debug, thiserror::Error)]
pub enum LiveError {
    /// The address is not `HOST:PORT`.
    #[error("foxglove address {0:?} is not HOST:PORT")]
    Address(String),
    /// The server could not bind or start.
    #[error("foxglove server on {address}: {source}")]
    Start {
        /// The address asked for.
        address: String,
        /// What failed.
        source: foxglove::FoxgloveError,
    },
}

/// A running live server: its channels and its parameter set. Dropping it stops the
/// server.
pub struct LiveServer {
    channels: RobotChannels,
    parameters: Arc<RobotParameters>,
    server: Option<WebSocketServerHandle>,
    path_logged_at_s: Option<f64>,
    armed: bool,
    _context: Arc<Context>,
}

impl LiveServer {
    /// Starts a server named `name` on `address` (`HOST:PORT`; port 0 picks a free one,
    /// [`LiveServer::port`]) whose parameter set holds `robot_file` (a robot file's TOML
    /// text, [`RobotParameters`]).
    pub fn start(address: &str, name: &str, robot_file: &str) -> Result<Self, LiveError> {
        let (host, port) = address
            .rsplit_once(':')
            .and_then(|(h, p)| Some((h.trim_matches(['[', ']']), p.parse::<u16>().ok()?)))
            .ok_or_else(|| LiveError::Address(address.to_string()))?;
        let context = Context::new();
        let parameters = Arc::new(RobotParameters::new(robot_file));
        let channels = RobotChannels::new(&context);
        let server = WebSocketServer::new()
            .context(&context)
            .name(name)
            .bind(host, port)
            .capabilities([Capability::Parameters])
            .parameter_handler(parameters.clone())
            .start_blocking()
            .map_err(|source| LiveError::Start {
                address: address.to_string(),
                source,
            })?;
        Ok(Self {
            channels,
            parameters,
            server: Some(server),
            path_logged_at_s: None,
            armed: false,
            _context: context,
        })
    }

    /// The port the server listens on.
    pub fn port(&self) -> u16 {
        self.server.as_ref().map_or(0, WebSocketServerHandle::port)
    }

    /// Clients connected now.
    pub fn clients(&self) -> usize {
        self.server
            .as_ref()
            .map_or(0, WebSocketServerHandle::client_count)
    }

    /// Streams one sample ([`RobotChannels::log_sample`]) and, every 2 s of the run, the
    /// path (when known); the parameter set follows the sample's state (read-only while
    /// armed).
    pub fn log_sample(&mut self, row: &TraceRow, path: Option<&Path>) {
        // Due first, every PATH_EVERY_S after, and at once when the robot's clock went
        // back (a rebooted robot).
        let due = self
            .path_logged_at_s
            .is_none_or(|t| row.t_s < t || row.t_s - t >= PATH_EVERY_S);
        if let (true, Some(path)) = (due, path) {
            self.channels.log_path(path, row.t_s);
            self.path_logged_at_s = Some(row.t_s);
        }
        self.channels.log_sample(row);
        let armed = row.state == controller_core::supervisor::State::Armed;
        if armed != self.armed {
            self.armed = armed;
            self.parameters.set_read_only(armed);
        }
    }

    /// Samples streamed so far.
    pub fn samples(&self) -> u64 {
        self.channels.samples()
    }

    /// The changes clients asked for while the robot was disarmed, oldest first (the
    /// owner applies them to the robot and then calls [`LiveServer::publish_parameters`]).
    pub fn take_parameter_changes(&self) -> Vec<ParameterChange> {
        self.parameters.take_changes()
    }

    /// Replaces the parameter set by `robot_file` (the robot's configuration now) and
    /// tells the subscribed clients.
    pub fn publish_parameters(&self, robot_file: &str) {
        let values = self.parameters.replace(robot_file);
        if let Some(server) = &self.server {
            server.publish_parameter_values(values);
        }
    }

    /// Tells the clients something about their request (e.g. a parameter change the
    /// robot refused), as a status message.
    pub fn publish_status(&self, status: Status) {
        if let Some(server) = &self.server {
            server.publish_status(status);
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        if let Some(server) = self.server.take() {
            server.stop().wait_blocking();
        }
    }
}
