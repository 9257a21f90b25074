//! Checking a configuration or a committed path before it is staged, with refusals that
//! name the field and need no float formatting.

use controller_core::params::{Params, RobotConfig};
use controller_core::path::Segment;
use controller_core::reference::RebuildError;
use controller_core::supervisor::{geofence_radius_m, DivergenceCheck, SupervisorConfigError};
use heapless::String;
use link::{CommittedPath, FieldProblem, ParamSet, PathProblem, Refusal, FIELD_CAP};

use crate::channel::StagedPath;
use crate::stm32f4::bridge::BridgeChip;

/// Validates a `SetParams` configuration: the core's `Params::new` and
/// `SupervisorConfig::validate`, a control rate equal to the board's (`control_rate_hz`,
/// Hz), which is fixed by its tick timer, and a supply limit within the board's
/// `bridge` rating ([`within_bridge_rating`]). The refusal names the field (`robot.…` or
/// `supervisor.…`).
pub(crate) fn check(
    set: &ParamSet,
    control_rate_hz: u32,
    bridge: BridgeChip,
) -> Result<Params, Refusal> {
    let params = Params::new(set.robot)
        .map_err(|e| Refusal::InvalidParams(FieldProblem::from_param_error(&e)))?;
    within_bridge_rating(&set.robot, bridge).map_err(Refusal::InvalidParams)?;
    if set.robot.control_rate_hz != control_rate_hz {
        return Err(Refusal::InvalidParams(FieldProblem::new(
            "robot.control_rate_hz",
            "must stay the board's control rate",
        )));
    }
    set.supervisor
        .validate(&params)
        .map_err(|e| Refusal::InvalidParams(supervisor_problem(&e)))?;
    Ok(params)
}

/// `robot`'s supply limit (`drive.max_supply_v`, above which the supervisor faults) is
/// within what `bridge` is rated for; otherwise the field and the requirement. A robot
/// configured for a 12.6 V pack would otherwise arm and drive a DRV8833 above its
/// 10.8 V rating.
pub fn within_bridge_rating(robot: &RobotConfig, bridge: BridgeChip) -> Result<(), FieldProblem> {
    if robot.drive.max_supply_v <= bridge.max_supply_v() {
        Ok(())
    } else {
        Err(bridge_rating_problem(bridge))
    }
}

/// The field and the requirement a supply limit above `bridge`'s rating breaks.
pub fn bridge_rating_problem(bridge: BridgeChip) -> FieldProblem {
    FieldProblem::new(
        "robot.drive.max_supply_v",
        match bridge {
            BridgeChip::Tb6612fng => "must be ≤ 13.5 V, the TB6612FNG's rating",
            BridgeChip::Drv8833 => "must be ≤ 10.8 V, the DRV8833's rating",
        },
    )
}

/// The field (`supervisor.<field>`) and the requirement a [`SupervisorConfigError`]
/// breaks, without its values.
pub fn supervisor_problem(error: &SupervisorConfigError) -> FieldProblem {
    let requirement = error.requirement();
    let mut field = String::<FIELD_CAP>::new();
    for part in ["supervisor.", error.field()] {
        // Both parts are short; a cut would only shorten the name.
        let _ = field.push_str(part);
    }
    FieldProblem {
        field,
        problem: link::bounded(requirement),
    }
}

/// Builds, in `staged` (in place: no path or reference on the stack), a committed
/// upload with its `segments`: its reference (speed and mode from the upload's begin),
/// its law, and the supervisor settings in force with the upload's start pose and, where
/// enabled, the divergence check and geofence derived for the new path (both depend on
/// the path and the start pose; a geofence around the old path could stop the robot on
/// the new one).
pub(crate) fn stage_path(
    staged: &mut StagedPath,
    committed: &CommittedPath,
    segments: &[Segment],
    active: &ParamSet,
) -> Result<(), Refusal> {
    let begin = committed.begin;
    staged
        .reference
        .rebuild(segments, begin.speed_m_s, begin.mode)
        .map_err(|e| {
            Refusal::InvalidPath(match e {
                RebuildError::Path(e) => PathProblem::Geometry(e),
                RebuildError::Reference(e) => PathProblem::Reference(e),
            })
        })?;
    // In place too: the settings are not small.
    staged.law = begin.law;
    let supervisor = &mut staged.supervisor;
    *supervisor = active.supervisor;
    supervisor.start_pose = begin.start_pose;
    if supervisor.divergence.is_some() {
        supervisor.divergence = Some(DivergenceCheck::for_reference(
            &staged.reference,
            &supervisor.start_pose,
            active.robot.control_rate_hz,
        ));
    }
    if supervisor.geofence_radius_m.is_some() {
        supervisor.geofence_radius_m = Some(geofence_radius_m(
            staged.reference.path(),
            supervisor.start_pose,
        ));
    }
    staged.summary = committed.summary;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::kinematics::{Pose, WheelSpeeds};
    use controller_core::params::RobotConfig;
    use controller_core::supervisor::SupervisorConfig;
    use link::PROBLEM_CAP;

    fn set() -> ParamSet {
        ParamSet {
            robot: RobotConfig::REFERENCE_ROBOT,
            supervisor: SupervisorConfig::at_rate(1000, Pose::default(), WheelSpeeds::default()),
        }
    }

    fn refused_field(set: &ParamSet) -> (std::string::String, std::string::String) {
        refused_on(set, BridgeChip::Tb6612fng)
    }

    fn refused_on(
        set: &ParamSet,
        bridge: BridgeChip,
    ) -> (std::string::String, std::string::String) {
        match check(set, 1000, bridge) {
            Err(Refusal::InvalidParams(p)) => (p.field.as_str().into(), p.problem.as_str().into()),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_valid_configuration_passes() {
        assert!(check(&set(), 1000, BridgeChip::Tb6612fng).is_ok());
    }

    #[test]
    fn a_supply_limit_above_the_bridge_s_rating_is_refused() {
        // The reference robot's 13.5 V suits the TB6612FNG only.
        assert_eq!(
            refused_on(&set(), BridgeChip::Drv8833),
            (
                "robot.drive.max_supply_v".into(),
                "must be ≤ 10.8 V, the DRV8833's rating".into()
            )
        );
        let mut above = set();
        above.robot.drive.max_supply_v = 13.6;
        assert_eq!(refused_field(&above).0, "robot.drive.max_supply_v");
        let mut at = set();
        at.robot.drive.max_supply_v = 10.8;
        assert!(check(&at, 1000, BridgeChip::Drv8833).is_ok());
    }

    #[test]
    fn refusals_name_the_field() {
        let mut bad = set();
        bad.robot.wheel_radius_left_m = -0.03;
        assert_eq!(
            refused_field(&bad),
            ("robot.wheel_radius_left_m".into(), "must be > 0".into())
        );
        let mut bad = set();
        bad.supervisor.heartbeat_timeout_steps = 0;
        assert_eq!(
            refused_field(&bad),
            (
                "supervisor.heartbeat_timeout_steps".into(),
                "must be ≥ 1".into()
            )
        );
        let mut bad = set();
        bad.robot.control_rate_hz = 500;
        bad.robot.speed_window_steps = 40;
        assert_eq!(refused_field(&bad).0, "robot.control_rate_hz");
    }

    #[test]
    fn every_supervisor_requirement_fits_uncut() {
        use SupervisorConfigError as E;
        for e in [
            E::NonFiniteStartPose,
            E::NonFiniteHoldSpeeds,
            E::BadButtonTiming,
            E::ZeroOverrunLimit,
            E::ZeroBackgroundTimeout,
            E::BadMissedTickCheck,
            E::BadStallCheck,
            E::BadDivergenceCheck,
            E::BadGeofence,
            E::BadBatteryThresholds {
                warn_v: 0.0,
                fault_v: 0.0,
                min_supply_v: 0.0,
            },
            E::ZeroHeartbeatTimeout,
        ] {
            let p = supervisor_problem(&e);
            assert!(p.field.len() < FIELD_CAP, "{e:?}: {}", p.field);
            assert!(p.problem.len() < PROBLEM_CAP, "{e:?}: {}", p.problem);
            assert_eq!(p.field.as_str(), format!("supervisor.{}", e.field()));
        }
    }
}
