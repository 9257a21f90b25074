//! Building both sides from one configuration.

use core::fmt;

use controller_core::controller::Controller;
use controller_core::law::LawKind;
use controller_core::outer_loop::OuterLoop;
use controller_core::params::{ParamError, Params};
use controller_core::reference::Reference;
use controller_core::supervisor::{ResetCause, Supervisor, SupervisorConfigError};
use link::{FieldProblem, ParamSet};

use crate::channel::Channels;
use crate::control::ControlSide;
use crate::outer::{OuterLoopMailbox, OuterLoopSlot, OuterLoopWorker};
use crate::service::{Identity, LinkOptions, LinkService};
use crate::stm32f4::bridge::BridgeChip;

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
    /// Why the chip last reset (auto-arm only after a power-on or pin reset; `Info`
    /// reports it).
    pub reset: ResetCause,
    /// Who the robot is, for `Info`.
    pub identity: Identity,
    /// The link's baud rate, telemetry rate and storage.
    pub link: LinkOptions,
    /// The board's motor bridge: `params.robot.drive.max_supply_v` may not exceed its
    /// rating, at start nor in a later `SetParams`.
    pub bridge: BridgeChip,
}

/// Why the sides could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StartError {
    /// The robot configuration fails `Params::new`.
    Robot(ParamError),
    /// The supervisor settings fail `SupervisorConfig::validate`.
    Supervisor(SupervisorConfigError),
    /// The robot's supply limit is above the board's bridge rating
    /// ([`crate::service::within_bridge_rating`]).
    AboveBridgeRating(BridgeChip),
}

impl fmt::Display for StartError {
    /// The field and its requirement, no values (no float formatting).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let problem = match self {
            StartError::Robot(e) => FieldProblem::from_param_error(e),
            StartError::Supervisor(e) => crate::service::supervisor_problem(e),
            StartError::AboveBridgeRating(bridge) => crate::service::bridge_rating_problem(*bridge),
        };
        write!(f, "{problem}")
    }
}

/// No `source`: the message already states the field and its requirement, and a cause
/// printed after it would repeat them.
impl core::error::Error for StartError {}

/// The control side and the link side for `config`, talking through `channels`: the
/// controller (in `Idle`) at the supervisor's start pose on `config.reference`, the
/// supervisor `Disarmed`, and a link side that knows the same configuration.
pub fn start(
    channels: &mut Channels,
    config: AppConfig,
) -> Result<(ControlSide<'_>, LinkService<'_>), StartError> {
    let params = Params::new(config.params.robot).map_err(StartError::Robot)?;
    crate::service::within_bridge_rating(&config.params.robot, config.bridge)
        .map_err(|_| StartError::AboveBridgeRating(config.bridge))?;
    let supervisor_config = config.params.supervisor;
    let supervisor = Supervisor::new(supervisor_config, &params, config.reset)
        .map_err(StartError::Supervisor)?;
    let (link_end, control_end, (outer_sender, outer_receiver)) = channels.split_all();
    // The outer loop goes into its slot in the channels (just split, so it is the
    // holder's), built once, at start.
    let mut holder = OuterLoopMailbox::new(outer_sender);
    if let Some(slot) = holder.slot_mut() {
        *slot = OuterLoopSlot::built(OuterLoop::new(&params, config.reference, config.law));
    }
    let controller = Controller::with_holder(params, holder, supervisor_config.start_pose);
    Ok((
        ControlSide::new(
            control_end,
            controller,
            supervisor,
            OuterLoopWorker::new(outer_receiver),
        ),
        LinkService::new(
            link_end,
            config.identity,
            config.reset,
            config.params,
            config.link,
            config.bridge,
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn movable_between_contexts<T: Send>() {}

    /// RTIC moves each side into its task's resources: both must be `Send`.
    #[test]
    fn both_sides_can_move_to_their_tasks() {
        movable_between_contexts::<ControlSide<'static>>();
        movable_between_contexts::<LinkService<'static>>();
        movable_between_contexts::<crate::ControlEnd<'static>>();
        movable_between_contexts::<crate::LinkEnd<'static>>();
    }

    #[test]
    fn an_invalid_configuration_names_its_field() {
        use controller_core::kinematics::{Point, Pose, WheelSpeeds};
        use controller_core::params::RobotConfig;
        use controller_core::path::Path;
        use controller_core::reference::ReferenceMode;
        use controller_core::supervisor::SupervisorConfig;

        let line = Path::line(Point::new(0.0, 0.0), 0.0, 1.0).expect("a line");
        let mut robot = RobotConfig::REFERENCE_ROBOT;
        robot.track_width_m = 0.0;
        let config = AppConfig {
            params: ParamSet {
                robot,
                supervisor: SupervisorConfig::at_rate(
                    1000,
                    Pose::default(),
                    WheelSpeeds::default(),
                ),
            },
            reference: Reference::new(
                line,
                0.2,
                ReferenceMode::TimeIndexed {
                    start_offset_m: 0.0,
                },
            )
            .expect("a reference"),
            law: LawKind::Tracking,
            reset: ResetCause::PowerOn,
            identity: Identity {
                firmware_version: "",
                git_hash: "",
                chip: "",
                robot_name: "",
                clock: link::ClockSource::Simulated,
                brown_out_reset: link::BrownOutReset::Level3,
            },
            link: LinkOptions {
                baud: 115_200,
                telemetry_hz: 0,
                storage: false,
            },
            bridge: BridgeChip::Tb6612fng,
        };
        let mut channels = Channels::new();
        let error = start(&mut channels, config.clone()).err();
        assert_eq!(
            error.map(|e| e.to_string()),
            Some("robot.track_width_m must be > 0".into())
        );
        // A 13.5 V limit suits the TB6612FNG, not a DRV8833 (10.8 V).
        let mut config = config;
        config.params.robot = RobotConfig::REFERENCE_ROBOT;
        assert!(start(&mut Channels::new(), config.clone()).is_ok());
        config.bridge = BridgeChip::Drv8833;
        let error = start(&mut Channels::new(), config.clone()).err();
        assert_eq!(
            error.map(|e| e.to_string()),
            Some("robot.drive.max_supply_v must be ≤ 10.8 V, the DRV8833's rating".into())
        );
        config.params.robot.drive.max_supply_v = BridgeChip::Drv8833.max_supply_v();
        assert!(start(&mut Channels::new(), config.clone()).is_ok());
        config.params.supervisor.heartbeat_timeout_steps = 0;
        let error = start(&mut channels, config).err();
        assert_eq!(
            error.map(|e| e.to_string()),
            Some("supervisor.heartbeat_timeout_steps must be ≥ 1".into())
        );
    }
}
