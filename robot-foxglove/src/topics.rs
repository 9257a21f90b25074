//! The channels' topics and the coordinate frames, the same in a file and live (the
//! layout in `docs/foxglove-layout.json` names them).

/// The path's frame and the world frame of every pose: the odometry's origin, x forward
/// at the start, y to the left, z up; m and rad.
pub const WORLD_FRAME: &str = "odom";
/// The robot as its odometry estimates it (child of [`WORLD_FRAME`]).
pub const ESTIMATE_FRAME: &str = "base_link";
/// The robot where the simulator knows it truly is (child of [`WORLD_FRAME`]).
pub const TRUE_FRAME: &str = "base_link_true";
/// The reference the robot tracks (child of [`WORLD_FRAME`]).
pub const REFERENCE_FRAME: &str = "reference";

/// `FrameTransform`s from [`WORLD_FRAME`] to [`ESTIMATE_FRAME`], [`TRUE_FRAME`] and
/// [`REFERENCE_FRAME`].
pub const TF: &str = "/tf";
/// `PoseInFrame`: the odometry's estimate.
pub const POSE_ESTIMATE: &str = "/pose/estimate";
/// `PoseInFrame`: the true pose (only where it is known).
pub const POSE_TRUE: &str = "/pose/true";
/// `PoseInFrame`: the reference.
pub const POSE_REFERENCE: &str = "/pose/reference";
/// `SceneUpdate`: the path as a line, arcs tessellated.
pub const PATH: &str = "/path";
/// [`crate::messages::ErrorsMessage`].
pub const ERRORS: &str = "/errors";
/// [`crate::messages::BodyMessage`].
pub const BODY: &str = "/body";
/// [`crate::messages::WheelsMessage`].
pub const WHEELS: &str = "/wheels";
/// [`crate::messages::SupervisorMessage`].
pub const SUPERVISOR: &str = "/supervisor";
/// `Log`: arming, disarming, faults and the end of the run.
pub const EVENTS: &str = "/events";

/// Every topic (the true pose's carries messages only where the truth is known).
pub const ALL: [&str; 10] = [
    TF,
    POSE_ESTIMATE,
    POSE_TRUE,
    POSE_REFERENCE,
    PATH,
    ERRORS,
    BODY,
    WHEELS,
    SUPERVISOR,
    EVENTS,
];
