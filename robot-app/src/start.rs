//! Building both sides from one configuration.

use core::fmt;

use controller_core::controller::Controller;
use controller_core::law::LawKind;
use controller_core::params::{ParamError, Params};
use controller_core::reference::Reference;
use controller_core::supervisor::{ResetCause, Supervisor, SupervisorConfigError};
use link::{FieldProblem, ParamSet};

use crate::channel::Channels;
use crate::control::ControlSide;
use crate::service::{Identity, LinkOptions, LinkService};

/// Everything the board decides at start.
#[derive(Clone, Debug)]
pub struct AppConfig {
    /// The robot configuration and supervisor settings (persisted ones, or the board's
    /// defaults). The supervisor's `start_pose` is the controller's starting pose.
    pub params: ParamSet,
    /// The path to follow until the host commits another, its speed and mode.
    pub reference: Reference,
    /// The steering law.
    pub law: LawKind,
    /// Why the chip last reset (auto-arm only after a power-on or pin reset).
    pub reset: ResetCause,
    /// Who the robot is, for `Info`.
    pub identity: Identity,
    /// The link's baud rate, telemetry rate and storage.
    pub link: LinkOptions,
}

/// Why the sides could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StartError {
    /// The robot configuration fails `Params::new`.
    Robot(ParamError),
    /// The supervisor settings fail `SupervisorConfig::validate`.
    Supervisor(SupervisorConfigError),
}

impl fmt::Display for StartError {
    /// The field and its requirement, no values (no float formatting).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let problem = match self {
            StartError::Robot(e) => FieldProblem::from_param_error(e),
            StartError::Supervisor(e) => crate::service::supervisor_problem(e),
        };
        write!(f, "{problem}")
    }
}

/// The control side and the link side for `config`, talking through `channels`: the
/// controller (in `Idle`) at the supervisor's start pose on `config.reference`, the
/// supervisor `Disarmed`, and a link side that knows the same configuration.
pub fn start(
    channels: &mut Channels,
    config: AppConfig,
) -> Result<(ControlSide<'_>, LinkService<'_>), StartError> {
    let params = Params::new(config.params.robot).map_err(StartError::Robot)?;
    let supervisor_config = config.params.supervisor;
    let supervisor = Supervisor::new(supervisor_config, &params, config.reset)
        .map_err(StartError::Supervisor)?;
    let controller = Controller::new(
        params,
        config.reference,
        config.law,
        supervisor_config.start_pose,
    );
    let (link_end, control_end) = channels.split();
    Ok((
        ControlSide::new(control_end, controller, supervisor),
        LinkService::new(link_end, config.identity, config.params, config.link),
    ))
}
