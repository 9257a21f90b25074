//! The command line of `host-sim`: every command, its arguments and their help text
//! (`host-sim --help`). `main` dispatches each to [`host_sim::commands`].

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use robot_files::cli::Law;
use robot_files::scenario::HeadingChoice;

/// `--heading`: the heading a robot with a gyro steers by.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Heading {
    /// The gyro fused with odometry.
    Fused,
    /// Odometry alone (today's robot).
    Odometry,
    /// The true heading (an ideal gyro; simulation only).
    Oracle,
}

impl From<Heading> for HeadingChoice {
    fn from(h: Heading) -> Self {
        match h {
            Heading::Fused => HeadingChoice::Fused,
            Heading::Odometry => HeadingChoice::Odometry,
            Heading::Oracle => HeadingChoice::Oracle,
        }
    }
}

/// Differential-drive robot simulator for the Jin & Tack (2011) path-following stack.
#[derive(Parser)]
#[command(name = "host-sim", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Run one scenario: writes trace.csv, summary.json and Figs. 5–7 (SVG) into --out.
    Run {
        /// Built-in scenario name (see `list`) or a path to a .toml file.
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// Output directory [default: host-sim-out/<scenario>/<law>].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Trace row every N control steps (1 = every step) [default: every steering
        /// update, the scenario's robot.steering_divider].
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        trace_every: Option<u32>,
        /// Simulated time, s, instead of the scenario's sim.duration_s (up to 86 400: a
        /// 24 h soak is `--duration-s 86400`).
        #[arg(long)]
        duration_s: Option<f64>,
        /// Also write the run as an MCAP file (Foxglove: poses, path, telemetry, events;
        /// the trace's samples at simulated time).
        #[arg(long)]
        mcap: Option<PathBuf>,
    },
    /// Reproduce the paper: its circle and line experiments with every law, Figs. 5–7 and
    /// summary.json for each run, an overlay per experiment, a table and the verdict.
    Paper {
        /// Output directory [default: host-sim-out/paper].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Every law on the same plant: a table on stdout and compare.svg in --out.
    Compare {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        /// Output directory [default: host-sim-out/<scenario>/compare].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Monte-Carlo over mismatch, noise and start pose (the scenario's [sweep] spreads),
    /// on every core.
    Sweep {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        /// Number of runs.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// Seed of the draws.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Also write sweep.json (every run's draws and results) into this directory.
        #[arg(long)]
        out: Option<PathBuf>,
        /// The heading steered by, for a scenario with a [gyro] (default: the scenario's).
        #[arg(long, value_enum)]
        heading: Option<Heading>,
        /// Also write each run as an MCAP file (Foxglove), run-NNNN.mcap, into this
        /// directory.
        #[arg(long)]
        mcap_dir: Option<PathBuf>,
    },
    /// The velocity mode's figures: a step in the command reaching the limited command,
    /// the ramp to zero after the last command, and the limits held; one line, and a
    /// failure when they break the mode's contract.
    VelocityCheck {
        /// Built-in scenario name or a path to a .toml file with a [velocity] timeline.
        #[arg(default_value = "velocity-steps")]
        scenario: String,
    },
    /// Wheel-speed loop alone: a set-point step from rest, to tune the wheel PID.
    StepResponse {
        /// Built-in scenario name or a path to a .toml file (its robot and plant are used).
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Set-point, rad/s (wheel).
        #[arg(long, default_value_t = 15.0, allow_negative_numbers = true)]
        setpoint_rad_s: f64,
        /// Duration, s.
        #[arg(long, default_value_t = 1.0)]
        duration_s: f64,
        /// Output directory for step_response.svg [default: host-sim-out/<scenario>/step].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Every kind of fault, one at a time, on a built-in scenario: what the supervisor did,
    /// how fast, against its detector's limit. Prints a table, writes faults.json, and
    /// fails if a case did not behave as stated.
    Faults {
        /// Built-in scenario name or a path to a .toml file.
        #[arg(default_value = "paper-circle")]
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// Output directory for faults.json [default: host-sim-out/<scenario>/faults].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also write each case's run as an MCAP file (Foxglove), named after the case,
        /// into this directory.
        #[arg(long)]
        mcap_dir: Option<PathBuf>,
        /// Every row in every configuration a user can arm (heading source × mode × armed
        /// at rest or in motion) on the scenario: one line, the failed cells, and
        /// matrix.json and matrix.md (the table docs/safety.md carries) in --out.
        #[arg(long, conflicts_with = "mcap_dir")]
        matrix: bool,
    },
    /// Processor in the loop: the firmware, built for the Cortex-M4F with its `qemu` board,
    /// runs under qemu-system-arm against this simulator's plant in lockstep, and a ground
    /// station drives it over its link (the station port). Prints the firmware's figures,
    /// compares the run with `host-sim run`, writes summary.json and pil.json into --out.
    Pil {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// The firmware ELF [default: target/thumbv7em-none-eabihf/firmware/firmware, as
        /// built by `cargo build --profile firmware -p firmware --target
        /// thumbv7em-none-eabihf --features qemu`].
        #[arg(long)]
        firmware: Option<PathBuf>,
        /// The QEMU binary.
        #[arg(long, default_value = "qemu-system-arm")]
        qemu: PathBuf,
        /// TCP port of the firmware's link for a ground station (0: any free port, printed).
        #[arg(long, default_value_t = 0)]
        station_port: u16,
        /// Who drives the link: the built-in minimal station, or none (connect your own to
        /// the station port).
        #[arg(long, value_enum, default_value_t = Client::Builtin)]
        client: Client,
        /// Simulated time, s, instead of the scenario's sim.duration_s.
        #[arg(long)]
        duration_s: Option<f64>,
        /// Cut the link this many seconds after arming (a link-loss test).
        #[arg(long)]
        link_loss_at_s: Option<f64>,
        /// How long the station may take to arm the robot, s (wall clock).
        #[arg(long, default_value_t = 300)]
        arm_timeout_s: u64,
        /// Output directory [default: host-sim-out/<scenario>/pil].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// The wheel loop's gain and phase margins in every load case (ground straight and
    /// turning, lifted; motoring and braking), from the linearised loop; `--measure`
    /// cross-checks them with a frequency sweep on the simulated robot.
    Margins {
        /// Built-in scenario name or a path to a .toml file (its robot and plant are used).
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Also measure the loop by injecting sines on the simulated robot.
        #[arg(long)]
        measure: bool,
        /// Amplitude of the injected sine, V.
        #[arg(long, default_value_t = 0.5)]
        amplitude_v: f64,
    },
    /// The wheel loop with its gains fixed against supplies from 4.8 to 12.6 V and motors
    /// with R_a, K_t, friction and inertia ±30 %: margins, a step, the scenario; a table.
    ParamSweep {
        /// Built-in scenario name or a path to a .toml file.
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Also every combination of the four parameters at ±30 % at 4.8 and 12.6 V.
        #[arg(long)]
        corners: bool,
    },
    /// The virtual robot: the robot's own application logic (supervisor, controller, link
    /// service) against the simulated hardware, speaking the runtime link on a TCP port,
    /// with ground truth. Drive it with `station --connect ADDRESS …`.
    Serve {
        /// Built-in scenario name or a path to a .toml file (robot, plant, initial path).
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Address to listen on.
        #[arg(long, default_value = "127.0.0.1:5760")]
        listen: String,
        /// Simulated time per wall-clock time (1 = real time).
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
        /// Miswire the robot between the plant and its board, over the scenario's
        /// `[virtual_robot] miswire`: a comma-separated list of left-motor-inverted,
        /// right-motor-inverted, left-encoder-inverted, right-encoder-inverted,
        /// encoders-swapped, motors-swapped, gyro-inverted, cpr=xK, supply-scale=F.
        #[arg(long)]
        miswire: Option<String>,
        /// For tests: read the bench's hands from standard input, one command a line
        /// (`turn left 1`, `turn right -0.5`, `rotate 1`, `press 2000`, `led`,
        /// `measure`), each answered on standard output with a line starting `hands: `.
        #[arg(long)]
        hands: bool,
        /// Also stream the robot live to Foxglove (WebSocket, subprotocol
        /// foxglove.sdk.v1) on this address, with its parameters as a parameter set
        /// (read-only while armed).
        #[arg(long, num_args = 0..=1, default_missing_value = "127.0.0.1:8765", value_name = "ADDR")]
        foxglove: Option<String>,
        /// Samples per second of robot time on the Foxglove stream, Hz.
        #[arg(long, default_value_t = 100)]
        foxglove_hz: u32,
    },
    /// The core's wheel-loop tune on the simulated robot (ground or lifted, the scenario's
    /// `[plant] load`): the identified model against the linearised plant, the gains (as
    /// robot-file sections), a 0 → 15 rad/s step at 6 V tuned vs the scenario's gains
    /// (SVG) and the scenario's settle time with both.
    Tune {
        /// Built-in scenario name or a path to a .toml file.
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Output directory for the plot (default: out/<scenario>/tune).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also the acceptance sweep: the tune on 27 robots (the nominal motor at 5–12.6 V,
        /// R_a, K_t and inertia ±40 % and friction ×3, one at a time and at every corner)
        /// against their linearised truth, and each tuned loop's step.
        #[arg(long)]
        sweep: bool,
        /// SIMC's τ_c over the loop's effective dead time (default: the core's).
        #[arg(long)]
        tau_c_per_dead_time: Option<f32>,
        /// The longest hold and step of the tune, s (default: the core's).
        #[arg(long)]
        max_hold_s: Option<f32>,
        /// Tune with the wheels lifted (the plant's load set to `lifted`): τ is corrected
        /// for the chassis before the PI is set.
        #[arg(long)]
        lifted: bool,
    },
    /// List the built-in scenarios.
    List,
    /// Print a built-in scenario's TOML (a starting point for your own).
    Show {
        /// Built-in scenario name.
        name: String,
    },
}

/// Who drives the link of a processor-in-the-loop run.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Client {
    /// The built-in minimal station (host_sim::pil::station).
    Builtin,
    /// Nobody: connect a station to the station port.
    None,
}
