//! The station's command line: the clap definitions `main` dispatches on.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use robot_files::cli::Law;
use station::calibrate;

/// Ground station for the differential-drive robot and its virtual twin.
#[derive(Parser)]
#[command(
    name = "station",
    version,
    about,
    long_about = None,
    after_help = "Exit status: 0 done; 1 error; 2 bad command line; 3 a run did not end as \
asked (`run` or a `calibrate` run not at its time limit, `record --duration-s` cut short, a \
`tune` that did not finish): what ended it is printed, and what was recorded is written, \
a run's summary.json marked \"complete\": false."
)]
pub(crate) struct Cli {
    #[command(flatten)]
    pub(crate) link: LinkArgs,
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Args)]
pub(crate) struct LinkArgs {
    /// Serial port of the robot (e.g. /dev/ttyACM0; `station ports` lists them).
    #[arg(long, global = true, conflicts_with = "connect")]
    pub(crate) port: Option<String>,
    /// Baud rate of the serial port (8N1).
    #[arg(long, global = true, default_value_t = link::LINK_BAUD)]
    pub(crate) baud: u32,
    /// TCP address of a virtual robot (`host-sim serve --listen 127.0.0.1:5760`).
    #[arg(long, global = true)]
    pub(crate) connect: Option<String>,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// List the serial ports.
    Ports,
    /// Who the robot is: protocol, firmware, chip, name, parameter hash.
    Info,
    /// The robot's parameters, as a robot file (the `[robot]` and `[supervisor]` sections
    /// of host-sim scenarios).
    #[command(subcommand)]
    Params(ParamsCommand),
    /// Path upload.
    #[command(subcommand)]
    Path(PathCommand),
    /// Arm the robot to follow its path (from rest) and keep it armed: heartbeats and the
    /// live view until the robot stops, or Ctrl-C, which disarms first.
    Arm {
        /// Telemetry rate of the live view, Hz.
        #[arg(long, default_value_t = 10)]
        hz: u8,
    },
    /// Drive the robot from the keyboard in its velocity mode: ↑↓ or w/s change the speed,
    /// ←→ or a/d the turn, space stops, q (or Esc, Ctrl-C) stops, disarms and quits. The
    /// command is sent every 50 ms; the robot stops by its own timeout 0.5 s after the
    /// last. Needs a terminal on stdin.
    Drive,
    /// Tune the wheel loops: the robot, on the floor with 1.5 m free ahead and
    /// behind, drives its wheels open loop forward and back, identifies them and computes
    /// their PI; prints the model and the gains as robot-file sections (for `params set`).
    Tune {
        /// Give up (and disarm) after this long, s.
        #[arg(long, default_value_t = 60.0)]
        timeout_s: f64,
    },
    /// Tell the disarmed robot where it is (the pose command, in the path's frame): its
    /// odometry is set there and its next run starts the path afresh. Arming never sets
    /// the pose; after moving the robot by hand, send this (or long-press its button to
    /// say it stands at the path's start).
    Pose {
        /// x, m.
        #[arg(long, allow_negative_numbers = true)]
        x_m: f32,
        /// y, m.
        #[arg(long, allow_negative_numbers = true)]
        y_m: f32,
        /// Heading, rad, counter-clockwise from +x.
        #[arg(long, allow_negative_numbers = true)]
        theta_rad: f32,
    },
    /// Disarm.
    Disarm,
    /// Emergency stop (latches a fault; `clear-faults` to recover).
    Estop,
    /// Acknowledge latched faults.
    ClearFaults,
    /// Timing and link statistics.
    Stats,
    /// Live view of the telemetry, redrawn in place (Ctrl-C to quit).
    Watch {
        /// Telemetry rate, Hz.
        #[arg(long, default_value_t = 10)]
        hz: u8,
        /// Also stream the telemetry live to Foxglove (WebSocket, subprotocol
        /// foxglove.sdk.v1) on this address, at the telemetry rate, with the robot's
        /// parameters as a parameter set (read-only while armed).
        #[arg(long, num_args = 0..=1, default_missing_value = "127.0.0.1:8765", value_name = "ADDR")]
        foxglove: Option<String>,
    },
    /// Record telemetry (and the virtual robot's ground truth) to DIR/telemetry.csv until
    /// Ctrl-C or --duration-s.
    Record {
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Telemetry rate, Hz.
        #[arg(long, default_value_t = 100)]
        hz: u8,
        /// Stop after this many seconds of the robot's time.
        #[arg(long)]
        duration_s: Option<f64>,
        /// Also write the recording as an MCAP file (Foxglove: poses, telemetry, events;
        /// at the robot's own time).
        #[arg(long)]
        mcap: Option<PathBuf>,
    },
    /// Run a scenario on the robot: upload its path, arm (in motion if it starts moving),
    /// record until its duration or a fault, disarm, and write trace.csv, summary.json and
    /// Figs. 5–7 as `host-sim run` does.
    Run {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Telemetry rate, Hz (the trace's rate; lower ones are tried if the link is slow).
        #[arg(long, default_value_t = 100)]
        hz: u8,
        /// Also write the run as an MCAP file (Foxglove: poses, path, telemetry, events;
        /// the trace's samples at the robot's own time).
        #[arg(long)]
        mcap: Option<PathBuf>,
    },
    /// UMBmark odometry calibration: squares clockwise and counter-clockwise, the measured
    /// end points, the corrected wheel radii and track width; then a straight run against
    /// a tape for the common scale.
    Calibrate(calibrate::CalibrateArgs),
}

#[derive(Subcommand)]
pub(crate) enum ParamsCommand {
    /// Print the robot's parameters as a robot file (`station params get > robot.toml`).
    Get,
    /// Send a robot file's parameters (keys left out keep the robot's values).
    Set {
        /// The robot file.
        file: PathBuf,
        /// Also save them in the robot's flash.
        #[arg(long)]
        persist: bool,
    },
    /// Save the active parameters in the robot's flash.
    Persist,
}

#[derive(Subcommand)]
pub(crate) enum PathCommand {
    /// Upload a scenario's path, reference speed and mode, and start pose.
    Upload {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
    },
}
