//! The ROS 2 messages the bridge sends and receives, as serde structs whose field order is
//! the `.msg` files' (RustDDS writes them as CDR, little-endian, in declaration order).
//!
//! On DDS a ROS 2 type `pkg/msg/Type` is named `pkg::msg::dds_::Type_` and a topic `name`
//! is `rt/name`; [`MessageType`] holds the `pkg` and `Type` halves that ros2-client joins.
//! Fixed-size arrays (`float64[36]`) are written as their elements with no length, as CDR
//! has them; variable ones (`T[]`, `string`) with a 32-bit length first.

use ros2_client::builtin_interfaces::Time;
use serde::{Deserialize, Serialize};

/// The package and name of a ROS 2 message type (`geometry_msgs`, `Twist`).
pub trait MessageType {
    /// The package, `geometry_msgs`.
    const PACKAGE: &'static str;
    /// The type's name in its package, `Twist`.
    const NAME: &'static str;
}

macro_rules! message_type {
    ($ty:ty, $package:literal, $name:literal) => {
        impl MessageType for $ty {
            const PACKAGE: &'static str = $package;
            const NAME: &'static str = $name;
        }
    };
}

/// `geometry_msgs/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Twist`: a body velocity, linear in m/s and angular in rad/s, in the
/// frame of the robot's base (x forward, z up).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity, m/s (`x` forward).
    pub linear: Vector3,
    /// Angular velocity, rad/s (`z` counter-clockwise seen from above).
    pub angular: Vector3,
}
message_type!(Twist, "geometry_msgs", "Twist");

/// `std_msgs/Header`: when and in which frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Time of the data (the station's clock).
    pub stamp: Time,
    /// The coordinate frame of the data (`odom`, `base_link`).
    pub frame_id: String,
}

/// `geometry_msgs/TwistStamped`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// Time and frame.
    pub header: Header,
    /// The velocity.
    pub twist: Twist,
}
message_type!(TwistStamped, "geometry_msgs", "TwistStamped");

/// `geometry_msgs/Point`, m.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
    /// z, m.
    pub z: f64,
}

/// `geometry_msgs/Quaternion` (x, y, z, w; the identity is w = 1).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Quaternion {
    /// The rotation by `yaw_rad` about z (counter-clockwise seen from above).
    pub fn from_yaw(yaw_rad: f64) -> Self {
        let (sin, cos) = (yaw_rad / 2.0).sin_cos();
        Self {
            x: 0.0,
            y: 0.0,
            z: sin,
            w: cos,
        }
    }

    /// The rotation's yaw about z, rad in (−π, π]: a planar robot's heading.
    pub fn yaw_rad(&self) -> f64 {
        let sin_cos_pitch = 2.0 * (self.w * self.z + self.x * self.y);
        let cos_cos_pitch = 1.0 - 2.0 * (self.y * self.y + self.z * self.z);
        sin_cos_pitch.atan2(cos_cos_pitch)
    }
}

impl Default for Quaternion {
    fn default() -> Self {
        Self::from_yaw(0.0)
    }
}

/// `geometry_msgs/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position, m.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseStamped`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Time and frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// A row-major 6 × 6 covariance (x, y, z, rotation about x, y, z), as ROS 2's `float64[36]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Covariance {
    /// The covariance with `diagonal` on its diagonal and zeros elsewhere.
    pub fn from_diagonal(diagonal: [f64; 6]) -> Self {
        let mut matrix = [0.0; 36];
        for (i, value) in diagonal.into_iter().enumerate() {
            matrix[i * 7] = value;
        }
        Self(matrix)
    }
}

impl Default for Covariance {
    fn default() -> Self {
        Self([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple as _;
        let mut tuple = serializer.serialize_tuple(36)?;
        for value in &self.0 {
            tuple.serialize_element(value)?;
        }
        tuple.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Elements;
        impl<'de> serde::de::Visitor<'de> for Elements {
            type Value = Covariance;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("36 numbers")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> Result<Covariance, A::Error> {
                let mut matrix = [0.0; 36];
                for (i, slot) in matrix.iter_mut().enumerate() {
                    *slot = seq
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(matrix))
            }
        }
        deserializer.deserialize_tuple(36, Elements)
    }
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Its covariance (m², rad²).
    pub covariance: Covariance,
}

/// `geometry_msgs/PoseWithCovarianceStamped`: the bridge's `set_pose` topic (as
/// robot_localization's), where the robot's odometry is told where it is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    /// Time and frame.
    pub header: Header,
    /// The pose and its covariance.
    pub pose: PoseWithCovariance,
}
message_type!(
    PoseWithCovarianceStamped,
    "geometry_msgs",
    "PoseWithCovarianceStamped"
);

/// `geometry_msgs/TwistWithCovariance`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The velocity.
    pub twist: Twist,
    /// Its covariance ((m/s)², (rad/s)²).
    pub covariance: Covariance,
}

/// `nav_msgs/Odometry`: the pose in `header.frame_id` (odom), the velocity in
/// `child_frame_id` (base_link).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Time and the pose's frame.
    pub header: Header,
    /// The velocity's frame.
    pub child_frame_id: String,
    /// The pose, m and rad.
    pub pose: PoseWithCovariance,
    /// The body velocity, m/s and rad/s.
    pub twist: TwistWithCovariance,
}
message_type!(Odometry, "nav_msgs", "Odometry");

/// `nav_msgs/Path`: poses in `header.frame_id`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Path {
    /// Time and frame.
    pub header: Header,
    /// The poses, in order.
    pub poses: Vec<PoseStamped>,
}
message_type!(Path, "nav_msgs", "Path");

/// `geometry_msgs/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation, m.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`: `child_frame_id` seen from `header.frame_id`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Time and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`: the `tf` topic.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}
message_type!(TfMessage, "tf2_msgs", "TFMessage");

/// `sensor_msgs/JointState`: the wheels, positions in rad and velocities in rad/s.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Time and frame.
    pub header: Header,
    /// The joints' names.
    pub name: Vec<String>,
    /// Positions, rad.
    pub position: Vec<f64>,
    /// Velocities, rad/s.
    pub velocity: Vec<f64>,
    /// Efforts (empty: not measured).
    pub effort: Vec<f64>,
}
message_type!(JointState, "sensor_msgs", "JointState");

/// `diagnostic_msgs/KeyValue`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    /// The key.
    pub key: String,
    /// The value, as text.
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`DiagnosticStatus::OK`], [`DiagnosticStatus::WARN`], [`DiagnosticStatus::ERROR`]
    /// or [`DiagnosticStatus::STALE`].
    pub level: u8,
    /// What is reported on (`station ros2: link`).
    pub name: String,
    /// A line for people.
    pub message: String,
    /// The robot's name.
    pub hardware_id: String,
    /// The details.
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    /// All is well.
    pub const OK: u8 = 0;
    /// Something to look at.
    pub const WARN: u8 = 1;
    /// Not working.
    pub const ERROR: u8 = 2;
    /// No news.
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/DiagnosticArray`: the `diagnostics` topic.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Time.
    pub header: Header,
    /// One status per concern.
    pub status: Vec<DiagnosticStatus>,
}
message_type!(DiagnosticArray, "diagnostic_msgs", "DiagnosticArray");
