//! The robot: parameters, the built-in paths and the safety settings. The one place to edit
//! for another robot (geometry, encoders, gains) or another run.
//!
//! | Parameter                  | Value                               | Where            |
//! |----------------------------|-------------------------------------|------------------|
//! | Geometry, encoders, gains  | `RobotConfig::REFERENCE_ROBOT`      | [`ROBOT`]        |
//! | Motor bridge and its supply limit | TB6612FNG, 13.5 V (feature `drv8833`: DRV8833, 10.8 V) | [`BRIDGE`] |
//! | Wheel loop / steering rate | 1 kHz / 100 Hz                      | [`ROBOT`]        |
//! | Steering law               | `LawKind::Tracking`                 | [`LAW`]          |
//! | Built-in path              | paper's circle (feature `path-line`: line) | [`PATH`]  |
//! | Reference speed v_r        | 0.25 m/s                            | [`REFERENCE_SPEED_M_S`] |
//! | Bring-up hold speeds       | 5 rad/s both wheels                 | [`HOLD_SPEEDS`]  |
//! | Mode after reset           | path following (feature `bring-up`: hold) | [`supervisor_config`] |
//! | Auto-arm                   | off (feature `auto-arm`: 2 s after power-on) | [`supervisor_config`] |
//! | Run time limit             | 2 min armed, then disarm            | [`supervisor_config`] |
//! | Telemetry on the link      | 20 Hz from boot (the host may change it) | [`TELEMETRY_HZ`] |
//! | Name reported by `Info`    | `diff-drive`                        | [`ROBOT_NAME`]   |
//!
//! These are the built-in defaults; the link's `SetParams` replaces the configuration
//! and `PersistParams` keeps it in flash (the application's `persistence` module), and a
//! committed path upload replaces the built-in path until the next reset.

use core::f32::consts::FRAC_PI_3;

use controller_core::kinematics::{Point, Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::params::RobotConfig;
use controller_core::path::{Path, PathError};
use controller_core::reference::ReferenceMode;
use controller_core::reference::{Reference, ReferenceError};
use controller_core::supervisor::{RunMode, SupervisorConfig};
use link::ParamSet;
use robot_app::stm32f4::bridge::BridgeChip;
use robot_app::{AppConfig, Identity, LinkOptions};

use crate::board::{self, Board};

/// The board's motor bridge, chosen by the `drv8833` feature.
pub const BRIDGE: BridgeChip = if cfg!(feature = "drv8833") {
    BridgeChip::Drv8833
} else {
    BridgeChip::Tb6612fng
};

/// The robot's geometry, encoders, rates, limits and gains (the core validates them at
/// boot). The reference robot: 65 mm wheels, 150 mm track, 12-line encoders behind a 1:30
/// gearbox (1440 ticks per wheel turn), gains tuned in `host-sim`; its supply limit is
/// the [`BRIDGE`]'s rating.
pub const ROBOT: RobotConfig = {
    let mut robot = RobotConfig::REFERENCE_ROBOT;
    robot.drive.max_supply_v = BRIDGE.max_supply_v();
    robot
};

/// The steering law.
pub const LAW: LawKind = LawKind::Tracking;

/// Reference speed along the path, m/s.
pub const REFERENCE_SPEED_M_S: f32 = 0.25;

/// Wheel speeds held in bring-up mode, rad/s (5 rad/s ≈ 0.16 m/s of rim speed).
pub const HOLD_SPEEDS: WheelSpeeds = WheelSpeeds::new(5.0, 5.0);

/// Telemetry frames per second on the link from boot, Hz (the host's
/// `SetTelemetryRate` changes it; the link service caps it to what the baud rate
/// carries).
pub const TELEMETRY_HZ: u8 = 20;

/// The robot's name in the link's `Info`.
pub const ROBOT_NAME: &str = "diff-drive";

/// A path built into the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum BuiltInPath {
    /// The paper's experiment: circle x² + y² = 1.25² (m), counter-clockwise, the robot
    /// starting at (−1, −1.2) m heading 2π/3. Needs a 3 m × 3 m floor.
    Circle,
    /// A 2 m straight line along +x from the origin; the robot starts 0.2 m to its right
    /// (at (0, −0.2) m), heading along it.
    Line,
}

/// The path this build follows.
pub const PATH: BuiltInPath = if cfg!(feature = "path-line") {
    BuiltInPath::Line
} else {
    BuiltInPath::Circle
};

/// The paper's start pose for the circle (world frame, m and rad).
const CIRCLE_START: Pose = Pose {
    x_m: -1.0,
    y_m: -1.2,
    theta_rad: 2.0 * FRAC_PI_3,
};
/// Start pose for the line (world frame, m and rad).
const LINE_START: Pose = Pose {
    x_m: 0.0,
    y_m: -0.2,
    theta_rad: 0.0,
};

impl BuiltInPath {
    /// Where the robot is put down before arming (world frame, m and rad).
    pub const fn start_pose(self) -> Pose {
        match self {
            BuiltInPath::Circle => CIRCLE_START,
            BuiltInPath::Line => LINE_START,
        }
    }

    /// The path, and how its reference point moves: the paper's time-indexed virtual
    /// robot, starting at the path point nearest the start pose.
    pub fn build(self) -> Result<(Path, ReferenceMode), PathError> {
        let mode = ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        };
        let path = match self {
            BuiltInPath::Circle => {
                let start = CIRCLE_START;
                let angle = controller_core::math::atan2(start.y_m, start.x_m);
                Path::circle(Point::new(0.0, 0.0), 1.25, angle, true)?
            }
            BuiltInPath::Line => Path::line(Point::new(0.0, 0.0), 0.0, 2.0)?,
        };
        Ok((path, mode))
    }
}

/// Arming, timeouts and fault thresholds for this robot.
pub const fn supervisor_config() -> SupervisorConfig {
    let mut config =
        SupervisorConfig::at_rate(ROBOT.control_rate_hz, PATH.start_pose(), HOLD_SPEEDS);
    if cfg!(feature = "bring-up") {
        config.initial_mode = RunMode::HoldWheelSpeeds;
    }
    if cfg!(feature = "auto-arm") {
        // 2 s after a power-on or pin reset; never after a watchdog or software reset.
        config.auto_arm_after_steps = Some(2 * ROBOT.control_rate_hz);
    }
    // Stop by itself after 2 minutes armed (four laps of the circle).
    config.max_armed_steps = Some(120 * ROBOT.control_rate_hz);
    config
}

/// The built-in configuration: [`ROBOT`] and [`supervisor_config`].
pub const fn default_params() -> ParamSet {
    ParamSet {
        robot: ROBOT,
        supervisor: supervisor_config(),
    }
}

/// Why the built-in path could not be set up.
#[derive(Clone, Copy, Debug, PartialEq, defmt::Format)]
pub enum SetupError {
    /// The path's geometry.
    Path(PathError),
    /// Its reference speed or mode.
    Reference(ReferenceError),
}

/// Everything `robot_app::start` needs: the configuration in force `params`, its supply
/// limit held to the [`BRIDGE`]'s rating (a record persisted by a build for another
/// bridge may be above it), the built-in path at [`REFERENCE_SPEED_M_S`] with [`LAW`],
/// who the robot is and what `board` found at start (reset cause, clock source,
/// brown-out level, storage), and the link at the board's baud rate with
/// [`TELEMETRY_HZ`].
pub fn app_config(mut params: ParamSet, board: &Board) -> Result<AppConfig, SetupError> {
    let rating = BRIDGE.max_supply_v();
    if params.robot.drive.max_supply_v > rating {
        params.robot.drive.max_supply_v = rating;
    }
    let (path, mode) = PATH.build().map_err(SetupError::Path)?;
    let reference =
        Reference::new(path, REFERENCE_SPEED_M_S, mode).map_err(SetupError::Reference)?;
    Ok(AppConfig {
        params,
        reference,
        law: LAW,
        reset: board.reset,
        identity: Identity {
            firmware_version: env!("CARGO_PKG_VERSION"),
            git_hash: env!("FIRMWARE_GIT_HASH"),
            chip: board::NAME,
            robot_name: ROBOT_NAME,
            clock: board.clock,
            brown_out_reset: board.brown_out_reset,
        },
        link: LinkOptions {
            baud: board::LINK_BAUD,
            telemetry_hz: TELEMETRY_HZ,
            storage: board.storage.is_some(),
        },
        bridge: BRIDGE,
    })
}
