//! The bridge's ROS 2 parameters, named as `diff_drive_controller`'s where they mean the
//! same.
//!
//! Two kinds:
//!
//! - **The robot's** ([`ROBOT_PARAMETERS`]): the wheels' geometry, `cmd_vel_timeout` and
//!   the velocity mode's limits. The robot holds them ([`ParamSet`]); the bridge reads
//!   them from it when the link comes up and writes a change back with the link's
//!   parameter command ([`with_robot_parameter`] makes the new set). The robot holds the
//!   products: its left wheel radius is `wheel_radius × left_wheel_radius_multiplier`,
//!   its track `wheel_separation × wheel_separation_multiplier`. Read from the robot,
//!   `wheel_radius` is the mean of its two radii, the radius multipliers their ratios to
//!   it, and `wheel_separation_multiplier` 1.
//! - **The bridge's own** ([`BridgeParameters`]): `publish_rate`, `enable_odom_tf`, the
//!   covariances, the frames and wheel names, `use_stamped_vel`, and the path topic's
//!   `path_tolerance`, `path_speed` and `path_corner_radius`. The names and the kind of
//!   `cmd_vel` are fixed when the bridge starts (`--param NAME=VALUE`); the others may
//!   change while it runs.

use controller_core::params::RobotConfig;
use link::ParamSet;
use ros2_client::ParameterValue;

use super::odometry::OdometryFrames;

/// The parameters the robot holds.
pub const ROBOT_PARAMETERS: [&str; 12] = [
    "wheel_separation",
    "wheel_separation_multiplier",
    "wheel_radius",
    "left_wheel_radius_multiplier",
    "right_wheel_radius_multiplier",
    "cmd_vel_timeout",
    "linear.x.max_velocity",
    "linear.x.max_acceleration",
    "linear.x.max_jerk",
    "angular.z.max_velocity",
    "angular.z.max_acceleration",
    "angular.z.max_jerk",
];

/// Why a parameter value was refused.
#[derive(Clone, Debug, PartialEq)]
pub enum ParameterError {
    /// No such parameter.
    Unknown {
        /// Its name.
        name: String,
    },
    /// A value of another type than the parameter's.
    WrongType {
        /// The parameter.
        name: String,
        /// What it takes (`a double`, `6 doubles`).
        expected: &'static str,
    },
    /// A value outside what the parameter allows.
    OutOfRange {
        /// The parameter.
        name: String,
        /// What it allows (`> 0`, `1 to 100`).
        allowed: &'static str,
    },
    /// Set only when the bridge starts (`--param NAME=VALUE`).
    FixedAtStart {
        /// The parameter.
        name: String,
    },
}

impl core::fmt::Display for ParameterError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ParameterError::Unknown { name } => write!(f, "no parameter {name}"),
            ParameterError::WrongType { name, expected } => write!(f, "{name} takes {expected}"),
            ParameterError::OutOfRange { name, allowed } => {
                write!(f, "{name} must be {allowed}")
            }
            ParameterError::FixedAtStart { name } => write!(
                f,
                "{name} is set when the bridge starts (--param {name}=VALUE), not while it runs"
            ),
        }
    }
}

impl core::error::Error for ParameterError {}

/// The bridge-side factors of the robot's geometry (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Multipliers {
    /// `wheel_separation_multiplier`.
    pub wheel_separation: f64,
    /// `left_wheel_radius_multiplier`.
    pub left_wheel_radius: f64,
    /// `right_wheel_radius_multiplier`.
    pub right_wheel_radius: f64,
}

impl Multipliers {
    /// The factors that read `robot` as the module doc says: the radius multipliers the
    /// radii's ratios to their mean, the separation's 1.
    pub fn of(robot: &RobotConfig) -> Self {
        let mean = mean_radius(robot);
        Self {
            wheel_separation: 1.0,
            left_wheel_radius: f64::from(robot.wheel_radius_left_m) / mean,
            right_wheel_radius: f64::from(robot.wheel_radius_right_m) / mean,
        }
    }
}

fn mean_radius(robot: &RobotConfig) -> f64 {
    (f64::from(robot.wheel_radius_left_m) + f64::from(robot.wheel_radius_right_m)) / 2.0
}

/// The robot's parameters as ROS 2 parameters, in [`ROBOT_PARAMETERS`]' order.
pub fn robot_values(
    set: &ParamSet,
    multipliers: &Multipliers,
) -> Vec<(&'static str, ParameterValue)> {
    let robot = &set.robot;
    let v = &robot.velocity;
    let radius = robot.wheel_radius_left_m as f64 / multipliers.left_wheel_radius;
    let values = [
        f64::from(robot.track_width_m) / multipliers.wheel_separation,
        multipliers.wheel_separation,
        radius,
        multipliers.left_wheel_radius,
        multipliers.right_wheel_radius,
        f64::from(v.cmd_vel_timeout_steps) / f64::from(robot.control_rate_hz.max(1)),
        f64::from(v.linear_x.max_velocity),
        f64::from(v.linear_x.max_acceleration),
        f64::from(v.linear_x.max_jerk),
        f64::from(v.angular_z.max_velocity),
        f64::from(v.angular_z.max_acceleration),
        f64::from(v.angular_z.max_jerk),
    ];
    ROBOT_PARAMETERS
        .into_iter()
        .zip(values.map(ParameterValue::Double))
        .collect()
}

/// `value` as a finite double > 0 for `name` (an integer is taken as a double).
fn positive(name: &str, value: &ParameterValue) -> Result<f64, ParameterError> {
    let x = match value {
        ParameterValue::Double(x) => *x,
        ParameterValue::Integer(i) => *i as f64,
        _ => {
            return Err(ParameterError::WrongType {
                name: name.into(),
                expected: "a double",
            })
        }
    };
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(ParameterError::OutOfRange {
            name: name.into(),
            allowed: "finite and > 0",
        })
    }
}

/// The robot's set and the multipliers with `name` set to `value`; `Ok(None)` when
/// `name` is not one of the robot's. The robot validates the whole set when it is
/// written (its refusal names the field).
pub fn with_robot_parameter(
    set: &ParamSet,
    multipliers: &Multipliers,
    name: &str,
    value: &ParameterValue,
) -> Result<Option<(ParamSet, Multipliers)>, ParameterError> {
    if !ROBOT_PARAMETERS.contains(&name) {
        return Ok(None);
    }
    let x = positive(name, value)?;
    let mut set = *set;
    let mut m = *multipliers;
    let robot = &mut set.robot;
    let separation = f64::from(robot.track_width_m) / m.wheel_separation;
    let radius = f64::from(robot.wheel_radius_left_m) / m.left_wheel_radius;
    let geometry = |separation: f64, radius: f64, m: &Multipliers, robot: &mut RobotConfig| {
        robot.track_width_m = (separation * m.wheel_separation) as f32;
        robot.wheel_radius_left_m = (radius * m.left_wheel_radius) as f32;
        robot.wheel_radius_right_m = (radius * m.right_wheel_radius) as f32;
    };
    let v = &mut robot.velocity;
    match name {
        "wheel_separation" => geometry(x, radius, &m, robot),
        "wheel_separation_multiplier" => {
            m.wheel_separation = x;
            geometry(separation, radius, &m, robot);
        }
        "wheel_radius" => geometry(separation, x, &m, robot),
        "left_wheel_radius_multiplier" => {
            m.left_wheel_radius = x;
            geometry(separation, radius, &m, robot);
        }
        "right_wheel_radius_multiplier" => {
            m.right_wheel_radius = x;
            geometry(separation, radius, &m, robot);
        }
        "cmd_vel_timeout" => {
            let steps = (x * f64::from(robot.control_rate_hz)).round();
            if !(1.0..=f64::from(u32::MAX)).contains(&steps) {
                return Err(ParameterError::OutOfRange {
                    name: name.into(),
                    allowed: "at least one control period",
                });
            }
            robot.velocity.cmd_vel_timeout_steps = steps as u32;
        }
        "linear.x.max_velocity" => v.linear_x.max_velocity = x as f32,
        "linear.x.max_acceleration" => v.linear_x.max_acceleration = x as f32,
        "linear.x.max_jerk" => v.linear_x.max_jerk = x as f32,
        "angular.z.max_velocity" => v.angular_z.max_velocity = x as f32,
        "angular.z.max_acceleration" => v.angular_z.max_acceleration = x as f32,
        "angular.z.max_jerk" => v.angular_z.max_jerk = x as f32,
        _ => return Ok(None),
    }
    Ok(Some((set, m)))
}

/// The bridge's own parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct BridgeParameters {
    /// `publish_rate`: odom, tf and joint_states per second, Hz (1 to 100, the robot's
    /// telemetry rate; 50 by default, as diff_drive_controller's).
    pub publish_rate_hz: f64,
    /// `enable_odom_tf`: publish odom → base_link on `tf` (true).
    pub enable_odom_tf: bool,
    /// `use_stamped_vel`: `cmd_vel` is geometry_msgs/TwistStamped, not Twist (false;
    /// fixed at start).
    pub use_stamped_vel: bool,
    /// `odom_frame_id`, `base_frame_id`, `left_wheel_names`, `right_wheel_names` (fixed at
    /// start), the covariance diagonals.
    pub frames: OdometryFrames,
    /// `path_tolerance`: how far a pose of a path may be from the simplified path, m
    /// (0.02).
    pub path_tolerance_m: f64,
    /// `path_speed`: the reference speed along a path, m/s (0.2).
    pub path_speed_m_s: f64,
    /// `path_corner_radius`: the fillets' radius at the simplified path's corners, m
    /// (0.1; less where it does not fit).
    pub path_corner_radius_m: f64,
}

impl Default for BridgeParameters {
    fn default() -> Self {
        Self {
            publish_rate_hz: 50.0,
            enable_odom_tf: true,
            use_stamped_vel: false,
            frames: OdometryFrames::default(),
            path_tolerance_m: 0.02,
            path_speed_m_s: 0.2,
            path_corner_radius_m: 0.1,
        }
    }
}

/// The bridge's parameters that are fixed when it starts.
const FIXED_AT_START: [&str; 5] = [
    "use_stamped_vel",
    "odom_frame_id",
    "base_frame_id",
    "left_wheel_names",
    "right_wheel_names",
];

impl BridgeParameters {
    /// The parameters as ROS 2 parameters.
    pub fn values(&self) -> Vec<(&'static str, ParameterValue)> {
        let f = &self.frames;
        vec![
            ("publish_rate", ParameterValue::Double(self.publish_rate_hz)),
            (
                "enable_odom_tf",
                ParameterValue::Boolean(self.enable_odom_tf),
            ),
            (
                "use_stamped_vel",
                ParameterValue::Boolean(self.use_stamped_vel),
            ),
            (
                "odom_frame_id",
                ParameterValue::String(f.odom_frame_id.clone()),
            ),
            (
                "base_frame_id",
                ParameterValue::String(f.base_frame_id.clone()),
            ),
            (
                "left_wheel_names",
                ParameterValue::StringArray(vec![f.wheel_joint_names[0].clone()]),
            ),
            (
                "right_wheel_names",
                ParameterValue::StringArray(vec![f.wheel_joint_names[1].clone()]),
            ),
            (
                "pose_covariance_diagonal",
                ParameterValue::DoubleArray(f.pose_covariance_diagonal.to_vec()),
            ),
            (
                "twist_covariance_diagonal",
                ParameterValue::DoubleArray(f.twist_covariance_diagonal.to_vec()),
            ),
            (
                "path_tolerance",
                ParameterValue::Double(self.path_tolerance_m),
            ),
            ("path_speed", ParameterValue::Double(self.path_speed_m_s)),
            (
                "path_corner_radius",
                ParameterValue::Double(self.path_corner_radius_m),
            ),
        ]
    }

    /// Sets `name` to `value`; `Ok(false)` when `name` is not one of the bridge's.
    /// `at_start`: the bridge is starting, so the parameters fixed at start may be set.
    pub fn set(
        &mut self,
        name: &str,
        value: &ParameterValue,
        at_start: bool,
    ) -> Result<bool, ParameterError> {
        let known = self.values().iter().any(|(n, _)| *n == name);
        if !known {
            return Ok(false);
        }
        if !at_start && FIXED_AT_START.contains(&name) {
            return Err(ParameterError::FixedAtStart { name: name.into() });
        }
        let wrong = |expected| ParameterError::WrongType {
            name: name.into(),
            expected,
        };
        match (name, value) {
            ("publish_rate", _) => {
                let hz = positive(name, value)?;
                if !(1.0..=100.0).contains(&hz) {
                    return Err(ParameterError::OutOfRange {
                        name: name.into(),
                        allowed: "1 to 100 Hz (the robot's telemetry rates)",
                    });
                }
                self.publish_rate_hz = hz;
            }
            ("enable_odom_tf", ParameterValue::Boolean(b)) => self.enable_odom_tf = *b,
            ("use_stamped_vel", ParameterValue::Boolean(b)) => self.use_stamped_vel = *b,
            ("enable_odom_tf" | "use_stamped_vel", _) => return Err(wrong("true or false")),
            ("odom_frame_id", ParameterValue::String(s)) => self.frames.odom_frame_id = s.clone(),
            ("base_frame_id", ParameterValue::String(s)) => self.frames.base_frame_id = s.clone(),
            ("odom_frame_id" | "base_frame_id", _) => return Err(wrong("a string")),
            ("left_wheel_names", ParameterValue::StringArray(names)) if names.len() == 1 => {
                self.frames.wheel_joint_names[0] = names[0].clone();
            }
            ("right_wheel_names", ParameterValue::StringArray(names)) if names.len() == 1 => {
                self.frames.wheel_joint_names[1] = names[0].clone();
            }
            ("left_wheel_names" | "right_wheel_names", _) => {
                return Err(wrong("one name (a string array of one)"))
            }
            ("pose_covariance_diagonal" | "twist_covariance_diagonal", value) => {
                let diagonal = covariance_diagonal(name, value)?;
                if name == "pose_covariance_diagonal" {
                    self.frames.pose_covariance_diagonal = diagonal;
                } else {
                    self.frames.twist_covariance_diagonal = diagonal;
                }
            }
            ("path_tolerance", _) => self.path_tolerance_m = positive(name, value)?,
            ("path_speed", _) => self.path_speed_m_s = positive(name, value)?,
            ("path_corner_radius", _) => {
                self.path_corner_radius_m = match value {
                    ParameterValue::Double(0.0) => 0.0,
                    ParameterValue::Integer(0) => 0.0,
                    _ => positive(name, value)?,
                }
            }
            _ => return Ok(false),
        }
        Ok(true)
    }

    /// The telemetry rate that gives `publish_rate`, Hz.
    pub fn telemetry_rate_hz(&self) -> u8 {
        self.publish_rate_hz.round().clamp(1.0, 100.0) as u8
    }
}

/// Six variances ≥ 0.
fn covariance_diagonal(name: &str, value: &ParameterValue) -> Result<[f64; 6], ParameterError> {
    match value {
        ParameterValue::DoubleArray(values) if values.len() == 6 => {
            if values.iter().all(|v| v.is_finite() && *v >= 0.0) {
                let mut out = [0.0; 6];
                out.copy_from_slice(values);
                Ok(out)
            } else {
                Err(ParameterError::OutOfRange {
                    name: name.into(),
                    allowed: "6 finite variances ≥ 0",
                })
            }
        }
        _ => Err(ParameterError::WrongType {
            name: name.into(),
            expected: "6 doubles",
        }),
    }
}

/// `NAME=VALUE` of the command line as a parameter value: `true`/`false`, a number, a
/// `[a, b, …]` list of numbers or of names, or else a string.
pub fn parse_assignment(text: &str) -> Result<(String, ParameterValue), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("`{text}` is not NAME=VALUE"))?;
    let value = value.trim();
    let parsed = if value == "true" || value == "false" {
        ParameterValue::Boolean(value == "true")
    } else if let Ok(x) = value.parse::<f64>() {
        ParameterValue::Double(x)
    } else if let Some(inner) = value.strip_prefix('[').and_then(|v| v.strip_suffix(']')) {
        let items: Vec<&str> = inner
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .collect();
        match items
            .iter()
            .map(|s| s.parse::<f64>())
            .collect::<Result<Vec<_>, _>>()
        {
            Ok(numbers) => ParameterValue::DoubleArray(numbers),
            Err(_) => ParameterValue::StringArray(items.iter().map(|s| s.to_string()).collect()),
        }
    } else {
        ParameterValue::String(value.to_string())
    };
    Ok((name.trim().to_string(), parsed))
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::supervisor::SupervisorConfig;

    fn robot_set() -> ParamSet {
        let mut robot = RobotConfig::REFERENCE_ROBOT;
        robot.wheel_radius_left_m = 0.0330;
        robot.wheel_radius_right_m = 0.0340;
        ParamSet {
            robot,
            supervisor: SupervisorConfig::at_rate(
                robot.control_rate_hz,
                Default::default(),
                Default::default(),
            ),
        }
    }

    fn value_of(values: &[(&str, ParameterValue)], name: &str) -> f64 {
        match values.iter().find(|(n, _)| *n == name) {
            Some((_, ParameterValue::Double(x))) => *x,
            other => panic!("{name}: {other:?}"),
        }
    }

    #[test]
    fn the_robots_geometry_reads_as_a_radius_and_its_multipliers() {
        let set = robot_set();
        let m = Multipliers::of(&set.robot);
        let values = robot_values(&set, &m);
        assert!((value_of(&values, "wheel_radius") - 0.0335).abs() < 1e-7);
        assert!((value_of(&values, "left_wheel_radius_multiplier") - 0.0330 / 0.0335).abs() < 1e-6);
        assert!(
            (value_of(&values, "right_wheel_radius_multiplier") - 0.0340 / 0.0335).abs() < 1e-6
        );
        assert_eq!(value_of(&values, "wheel_separation_multiplier"), 1.0);
        assert!(
            (value_of(&values, "wheel_separation") - f64::from(set.robot.track_width_m)).abs()
                < 1e-7
        );
        assert!((value_of(&values, "cmd_vel_timeout") - 0.5).abs() < 1e-9);
    }

    #[test]
    fn a_change_is_written_as_the_products_the_robot_holds() {
        let set = robot_set();
        let m = Multipliers::of(&set.robot);
        let (set2, m2) =
            with_robot_parameter(&set, &m, "wheel_radius", &ParameterValue::Double(0.04))
                .unwrap()
                .unwrap();
        assert!((f64::from(set2.robot.wheel_radius_left_m) - 0.04 * 0.0330 / 0.0335).abs() < 1e-6);
        assert!((f64::from(set2.robot.wheel_radius_right_m) - 0.04 * 0.0340 / 0.0335).abs() < 1e-6);
        assert_eq!(m2, m);
        let (set3, m3) = with_robot_parameter(
            &set2,
            &m2,
            "wheel_separation_multiplier",
            &ParameterValue::Double(1.1),
        )
        .unwrap()
        .unwrap();
        assert!(
            (f64::from(set3.robot.track_width_m) - 1.1 * f64::from(set.robot.track_width_m)).abs()
                < 1e-6
        );
        // Read back through the same multipliers, the separation is unchanged.
        let values = robot_values(&set3, &m3);
        assert!(
            (value_of(&values, "wheel_separation") - f64::from(set.robot.track_width_m)).abs()
                < 1e-6
        );
        let (set4, _) =
            with_robot_parameter(&set, &m, "cmd_vel_timeout", &ParameterValue::Double(0.25))
                .unwrap()
                .unwrap();
        assert_eq!(
            set4.robot.velocity.cmd_vel_timeout_steps,
            set.robot.control_rate_hz / 4
        );
        let (set5, _) =
            with_robot_parameter(&set, &m, "angular.z.max_jerk", &ParameterValue::Integer(90))
                .unwrap()
                .unwrap();
        assert_eq!(set5.robot.velocity.angular_z.max_jerk, 90.0);
    }

    #[test]
    fn bad_robot_values_are_refused_by_name() {
        let set = robot_set();
        let m = Multipliers::of(&set.robot);
        let refused = |name: &str, value| with_robot_parameter(&set, &m, name, &value).unwrap_err();
        assert!(matches!(
            refused("wheel_radius", ParameterValue::Double(-0.1)),
            ParameterError::OutOfRange { .. }
        ));
        assert!(matches!(
            refused(
                "linear.x.max_velocity",
                ParameterValue::String("fast".into())
            ),
            ParameterError::WrongType { .. }
        ));
        assert!(refused("cmd_vel_timeout", ParameterValue::Double(1e-6))
            .to_string()
            .contains("cmd_vel_timeout"));
        assert_eq!(
            with_robot_parameter(&set, &m, "publish_rate", &ParameterValue::Double(10.0)),
            Ok(None)
        );
    }

    #[test]
    fn the_bridges_own_parameters_check_their_values() {
        let mut p = BridgeParameters::default();
        assert_eq!(
            p.set("publish_rate", &ParameterValue::Double(20.0), false),
            Ok(true)
        );
        assert_eq!(p.telemetry_rate_hz(), 20);
        assert!(p
            .set("publish_rate", &ParameterValue::Double(500.0), false)
            .is_err());
        assert!(matches!(
            p.set("use_stamped_vel", &ParameterValue::Boolean(true), false),
            Err(ParameterError::FixedAtStart { .. })
        ));
        assert_eq!(
            p.set("use_stamped_vel", &ParameterValue::Boolean(true), true),
            Ok(true)
        );
        assert!(p.use_stamped_vel);
        let diagonal = ParameterValue::DoubleArray(vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6]);
        assert_eq!(
            p.set("pose_covariance_diagonal", &diagonal, false),
            Ok(true)
        );
        assert_eq!(p.frames.pose_covariance_diagonal[5], 0.6);
        assert!(p
            .set(
                "twist_covariance_diagonal",
                &ParameterValue::DoubleArray(vec![1.0]),
                false
            )
            .is_err());
        assert_eq!(
            p.set("wheel_radius", &ParameterValue::Double(0.1), false),
            Ok(false)
        );
    }

    #[test]
    fn command_line_assignments_take_their_types() {
        assert_eq!(
            parse_assignment("publish_rate=20").unwrap(),
            ("publish_rate".into(), ParameterValue::Double(20.0))
        );
        assert_eq!(
            parse_assignment("use_stamped_vel=true").unwrap().1,
            ParameterValue::Boolean(true)
        );
        assert_eq!(
            parse_assignment("pose_covariance_diagonal=[1, 2,3,4,5,6]")
                .unwrap()
                .1,
            ParameterValue::DoubleArray(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
        );
        assert_eq!(
            parse_assignment("left_wheel_names=[wheel_l]").unwrap().1,
            ParameterValue::StringArray(vec!["wheel_l".into()])
        );
        assert_eq!(
            parse_assignment("odom_frame_id=world").unwrap().1,
            ParameterValue::String("world".into())
        );
        assert!(parse_assignment("publish_rate").is_err());
    }
}
