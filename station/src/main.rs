//! `station`: drive the robot (serial) or the virtual robot (TCP) from a terminal.
//! `station --help` lists the commands.

use std::io::{IsTerminal as _, Write as _};
use std::path::{Path as FsPath, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use link::{Reply, Request, Uplink};
use robot_files::cli::Law;
use robot_files::metrics::{fault_names, ErrorReport};
use robot_files::output::settle_text;
use robot_files::scenario::Scenario;
use station::client::Client;
use station::record::{self, Recording, RunPlan};
use station::transport::{self, Serial, Tcp, Transport};
use station::{calibrate, ops, watch, NotAsAsked, EXIT_NOT_AS_ASKED};

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
struct Cli {
    #[command(flatten)]
    link: LinkArgs,
    #[command(subcommand)]
    command: Command,
}

#[derive(Args)]
struct LinkArgs {
    /// Serial port of the robot (e.g. /dev/ttyACM0; `station ports` lists them).
    #[arg(long, global = true, conflicts_with = "connect")]
    port: Option<String>,
    /// Baud rate of the serial port (8N1).
    #[arg(long, global = true, default_value_t = link::LINK_BAUD)]
    baud: u32,
    /// TCP address of a virtual robot (`host-sim serve --listen 127.0.0.1:5760`).
    #[arg(long, global = true)]
    connect: Option<String>,
}

#[derive(Subcommand)]
enum Command {
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
    /// Tune the wheel loops: the robot, on the floor with about a metre free ahead and
    /// behind, drives its wheels open loop forward and back, identifies them and computes
    /// their PI; prints the model and the gains as robot-file sections (for `params set`).
    Tune {
        /// Give up (and disarm) after this long, s.
        #[arg(long, default_value_t = 60.0)]
        timeout_s: f64,
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
    },
    /// UMBmark odometry calibration: squares clockwise and counter-clockwise, the measured
    /// end points, the corrected wheel radii and track width; then a straight run against
    /// a tape for the common scale.
    Calibrate(calibrate::CalibrateArgs),
}

#[derive(Subcommand)]
enum ParamsCommand {
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
enum PathCommand {
    /// Upload a scenario's path, reference speed and mode, and start pose.
    Upload {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
    },
}

/// `println!` that returns an error instead of panicking when stdout is closed.
macro_rules! say {
    ($($arg:tt)*) => {{
        writeln!(std::io::stdout(), $($arg)*)?
    }};
}

fn open(link: &LinkArgs) -> Result<Client<Box<dyn Transport>>> {
    let transport: Box<dyn Transport> = match (&link.port, &link.connect) {
        (Some(port), _) => Box::new(Serial::open(port, link.baud)?),
        (None, Some(address)) => Box::new(Tcp::connect(address)?),
        (None, None) => bail!(
            "no robot given: --port /dev/ttyACM0 (serial; `station ports` lists them) or \
--connect 127.0.0.1:5760 (the virtual robot of `host-sim serve`)"
        ),
    };
    let mut client = Client::new(transport);
    // Say who we talk to before anything else: a protocol mismatch shows here.
    ops::info(&mut client)?;
    Ok(client)
}

fn load(name: &str) -> Result<Scenario> {
    Scenario::load(name).with_context(|| format!("scenario {name}"))
}

/// Ctrl-C sets the flag (the first time); long commands disarm and stop when they see it.
fn interrupt_flag() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    let _ = ctrlc::set_handler(move || set.store(true, Ordering::Relaxed));
    flag
}

fn cmd_info(link: &LinkArgs) -> Result<()> {
    let mut client = open(link)?;
    let info = ops::info(&mut client)?;
    say!("robot       {}", info.robot_name);
    say!("chip        {}", info.chip);
    say!(
        "firmware    {} ({})",
        info.firmware_version,
        if info.git_hash.is_empty() {
            "no git hash"
        } else {
            info.git_hash.as_str()
        }
    );
    say!("protocol    {}", info.protocol);
    say!("parameters  hash 0x{:08x}", info.params_hash);
    say!("link        {}", client.transport().describe());
    Ok(())
}

fn cmd_params(link: &LinkArgs, command: ParamsCommand) -> Result<()> {
    let mut client = open(link)?;
    match command {
        ParamsCommand::Get => {
            let set = ops::get_params(&mut client)?;
            write!(std::io::stdout(), "{}", ops::params_to_toml(&set))?;
        }
        ParamsCommand::Set { file, persist } => {
            let text = std::fs::read_to_string(&file)
                .with_context(|| format!("reading {}", file.display()))?;
            let current = ops::get_params(&mut client)?;
            let set = ops::params_from_toml(&text, &file.display().to_string(), &current)?;
            let hash = ops::set_params(&mut client, set)?;
            say!("parameters applied (hash 0x{hash:08x})");
            if persist {
                client.command(Request::PersistParams)?;
                say!("parameters saved in the robot's flash");
            }
        }
        ParamsCommand::Persist => {
            client.command(Request::PersistParams)?;
            say!("parameters saved in the robot's flash");
        }
    }
    Ok(())
}

fn cmd_upload(link: &LinkArgs, scenario: &str, law: Law) -> Result<()> {
    let scenario = load(scenario)?;
    let mut client = open(link)?;
    let summary = ops::upload_path(
        &mut client,
        &scenario,
        law.into(),
        ops::fresh_upload_id(),
        &mut |_, _| {},
    )?;
    say!(
        "path of {} committed: {} segment{}, {:.3} m{}, checksum 0x{:08x}",
        scenario.name,
        summary.segment_count,
        if summary.segment_count == 1 { "" } else { "s" },
        summary.length_m,
        if summary.closed { " (closed)" } else { "" },
        summary.checksum
    );
    Ok(())
}

fn cmd_simple(link: &LinkArgs, request: Request, done: &str) -> Result<()> {
    let mut client = open(link)?;
    client.command(request)?;
    say!("{done}");
    Ok(())
}

fn cmd_stats(link: &LinkArgs) -> Result<()> {
    let mut client = open(link)?;
    if let Reply::Stats(s) = client.request(Request::GetStats)? {
        let r = s.link.received;
        // A robot that does not measure them (the virtual one) says 0.
        let measured = |value: u32, unit: &str| {
            if value == 0 {
                "not measured".to_string()
            } else {
                format!("{value} {unit}")
            }
        };
        say!(
            "control: longest step {}, missed ticks {}, overruns {}, stack {}",
            measured(s.max_step_cycles, "cycles"),
            s.missed_ticks,
            s.overruns,
            measured(s.stack_high_water_bytes, "B")
        );
        say!(
            "robot received: {} frames ok; dropped: {} CRC, {} framing, {} too long, {} other protocol, {} undecodable",
            r.frames_ok,
            r.crc_errors,
            r.format_errors,
            r.overflows,
            r.mismatches,
            r.decode_errors
        );
        say!(
            "robot sent: {} frames, {} telemetry samples dropped",
            s.link.frames_sent,
            s.link.telemetry_dropped
        );
    }
    Ok(())
}

fn cmd_tune(link: &LinkArgs, timeout_s: f64) -> Result<()> {
    if !(timeout_s.is_finite() && timeout_s > 0.0 && timeout_s <= 600.0) {
        anyhow::bail!("--timeout-s must be in (0, 600], got {timeout_s}");
    }
    let mut client = open(link)?;
    let timeout_steps = ops::get_params(&mut client)?
        .supervisor
        .heartbeat_timeout_steps;
    eprintln!("tuning: the robot drives about a metre forward and back…");
    let run = ops::tune(
        &mut client,
        timeout_steps,
        Duration::from_secs_f64(timeout_s),
    )?;
    let report = run.finished().map_err(NotAsAsked)?;
    say!("{}", ops::describe_tune(&report).trim_end());
    Ok(())
}

fn cmd_watch(link: &LinkArgs, hz: u8) -> Result<()> {
    let mut client = open(link)?;
    live_view(&mut client, hz, None)
}

/// Arms, then holds the robot armed with heartbeats under the live view until it stops on
/// its own (disarm, fault, end of run) or Ctrl-C, which disarms before returning.
fn cmd_arm(link: &LinkArgs, hz: u8) -> Result<()> {
    let mut client = open(link)?;
    let timeout = ops::get_params(&mut client)?
        .supervisor
        .heartbeat_timeout_steps;
    ops::arm(&mut client, None)?;
    let held = live_view(&mut client, hz, Some(record::HeartbeatPacer::new(timeout)));
    let disarmed = client.command(Request::Disarm);
    held?;
    disarmed?;
    say!("disarmed");
    Ok(())
}

/// The live view of the telemetry until Ctrl-C; with a `heartbeat` pacer, also the
/// heartbeats that keep a link-armed robot armed, until the robot leaves the armed state.
fn live_view(
    client: &mut station::client::Client<Box<dyn Transport>>,
    hz: u8,
    mut heartbeat: Option<record::HeartbeatPacer>,
) -> Result<()> {
    let interrupt = interrupt_flag();
    // Redrawn in place on a terminal; plain lines in a file or a pipe.
    let terminal = std::io::stdout().is_terminal();
    let rate = ops::get_params(client)?.robot.control_rate_hz;
    record::set_telemetry_rate(client, hz)?;
    let mut robot_step = None;
    let mut shown = 0;
    let mut pending: Option<link::TelemetryFrame> = None;
    let mut last_draw = Instant::now() - Duration::from_secs(1);
    while !interrupt.load(Ordering::Relaxed) {
        if let Some(pacer) = heartbeat.as_mut() {
            if pacer.due(robot_step) {
                client.send_only(Request::Heartbeat)?;
            }
        }
        let Some(message) = client.next_message(Duration::from_millis(20))? else {
            continue;
        };
        let (frame, truth) = match message {
            Uplink::Telemetry(f) => {
                robot_step = Some(f.step);
                let previous = pending.replace(f);
                match previous {
                    Some(p) => (p, None),
                    None => continue,
                }
            }
            Uplink::GroundTruth(g) => match pending.take() {
                Some(p) => (p, Some(g)),
                None => continue,
            },
            Uplink::Event { step, event } => {
                eprintln!("step {step}: {event:?}");
                shown = 0;
                let stopped = matches!(
                    event,
                    controller_core::supervisor::Event::Disarmed(_)
                        | controller_core::supervisor::Event::Faulted
                );
                if heartbeat.is_some() && stopped {
                    break;
                }
                continue;
            }
            _ => continue,
        };
        if last_draw.elapsed() < Duration::from_millis(50) {
            continue;
        }
        last_draw = Instant::now();
        let text = watch::screen(&frame, truth.as_ref(), rate);
        let mut out = std::io::stdout();
        write!(out, "{}{text}", watch::separator(shown, terminal))?;
        out.flush()?;
        shown = text.lines().count();
    }
    let _ = client.request(Request::SetTelemetryRate { hz: 1 });
    Ok(())
}

fn cmd_record(link: &LinkArgs, out: &FsPath, hz: u8, duration_s: Option<f64>) -> Result<()> {
    if let Some(d) = duration_s.filter(|d| !(d.is_finite() && *d > 0.0)) {
        bail!("--duration-s must be a positive number of seconds, got {d}");
    }
    let interrupt = interrupt_flag();
    let mut client = open(link)?;
    let rate = f64::from(ops::get_params(&mut client)?.robot.control_rate_hz);
    let hz = record::set_telemetry_rate(&mut client, hz)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let file = out.join("telemetry.csv");
    let mut csv = String::from(
        "step,t_s,state,x_est_m,y_est_m,theta_est_rad,x_e_m,y_e_m,theta_e_rad,\
setpoint_left_rad_s,setpoint_right_rad_s,speed_left_rad_s,speed_right_rad_s,duty_left,duty_right,\
supply_v,faults,x_true_m,y_true_m,theta_true_rad\n",
    );
    let mut pending: Option<link::TelemetryFrame> = None;
    let mut first: Option<u32> = None;
    let mut rows = 0u64;
    let period = (rate as u32 / u32::from(hz.max(1))).max(1);
    let mut frames = record::GapCounter::default();
    let mut last_k = 0u64;
    let push = |csv: &mut String,
                first: u32,
                f: &link::TelemetryFrame,
                g: Option<&link::GroundTruth>| {
        use std::fmt::Write as _;
        let t = f64::from(f.step.wrapping_sub(first)) / rate;
        let (gx, gy, gt) = g.map_or((f32::NAN, f32::NAN, f32::NAN), |g| {
            (g.pose.x_m, g.pose.y_m, g.pose.theta_rad)
        });
        let _ = writeln!(
            csv,
            "{},{t:.3},{:?},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.3},{},{gx:.6},{gy:.6},{gt:.6}",
            f.step,
            f.state,
            f.pose.x_m,
            f.pose.y_m,
            f.pose.theta_rad,
            f.tracking_error.x_e_m,
            f.tracking_error.y_e_m,
            f.tracking_error.theta_e_rad,
            f.wheel_setpoint.left_rad_s,
            f.wheel_setpoint.right_rad_s,
            f.wheel_speed.left_rad_s,
            f.wheel_speed.right_rad_s,
            f.duty.left,
            f.duty.right,
            f.supply_v,
            fault_names(&f.faults).join("|"),
        );
    };
    eprintln!(
        "recording at {hz} Hz to {} (Ctrl-C to stop)",
        file.display()
    );
    let limit = duration_s.map(|d| (d * rate) as u64);
    // Why the recording stopped before its duration, if it did.
    let mut cut_short = None;
    let mut reached = false;
    loop {
        if interrupt.load(Ordering::Relaxed) {
            break;
        }
        let message = match client.next_message(Duration::from_millis(50)) {
            Ok(Some(message)) => message,
            Ok(None) => continue,
            Err(e) => {
                cut_short = Some(format!("the link failed: {}", station::error_text(&e)));
                break;
            }
        };
        match message {
            Uplink::Telemetry(f) => {
                let start = *first.get_or_insert(f.step);
                let k = u64::from(f.step.wrapping_sub(start));
                // Steps 0 ≤ k < limit are the recording's: the frame at the limit is not.
                if limit.is_some_and(|limit| k >= limit) {
                    reached = true;
                    break;
                }
                last_k = k;
                frames.push(k, period);
                if let Some(p) = pending.replace(f) {
                    push(&mut csv, start, &p, None);
                    rows += 1;
                }
            }
            Uplink::GroundTruth(g) => {
                if let Some(p) = pending.take() {
                    let start = first.unwrap_or(p.step);
                    push(&mut csv, start, &p, Some(&g).filter(|g| g.step == p.step));
                    rows += 1;
                }
            }
            Uplink::Event { step, event } => eprintln!("step {step}: {event:?}"),
            _ => {}
        }
    }
    if let Some(p) = pending.take() {
        push(&mut csv, first.unwrap_or(p.step), &p, None);
        rows += 1;
    }
    std::fs::write(&file, csv).with_context(|| format!("writing {}", file.display()))?;
    say!("wrote {rows} rows to {}", file.display());
    let steps = match limit {
        Some(limit) if reached => limit,
        _ => last_k + 1,
    };
    let (received, missing) = frames.count(steps, period);
    say!(
        "telemetry: {received} of {} frames at {hz} Hz ({missing} missing)",
        received + missing
    );
    if received + missing > 0
        && missing as f64 > record::MISSING_TELEMETRY_WARNING * (received + missing) as f64
    {
        eprintln!(
            "warning: {missing} of {} telemetry frames are missing: the recording has gaps",
            received + missing
        );
    }
    match (duration_s, cut_short) {
        (_, Some(why)) => Err(NotAsAsked(format!(
            "the recording was cut short: {why}; what was recorded is in {}",
            file.display()
        ))
        .into()),
        (Some(d), None) if !reached => Err(NotAsAsked(format!(
            "the recording was interrupted (Ctrl-C) before its {d} s; what was recorded is in {}",
            file.display()
        ))
        .into()),
        _ => Ok(()),
    }
}

fn cmd_run(link: &LinkArgs, scenario: &str, law: Law, out: &FsPath, hz: u8) -> Result<()> {
    let interrupt = interrupt_flag();
    let scenario = load(scenario)?;
    let mut client = open(link)?;
    let robot = ops::get_params(&mut client)?;
    if robot.robot != scenario.robot {
        eprintln!(
            "note: the robot's [robot] parameters differ from the scenario's; the run uses \
the robot's (`station params set` sends a robot file)"
        );
    }
    let bar =
        ProgressBar::new((scenario.duration_s * f64::from(robot.robot.control_rate_hz)) as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let rate = f64::from(robot.robot.control_rate_hz);
    let mut progress = |done: u64, total: u64| {
        bar.set_position(done.min(total));
        bar.set_message(format!(
            "{:.1} / {:.1} s",
            done as f64 / rate,
            total as f64 / rate
        ));
    };
    let mut plan = RunPlan {
        scenario: &scenario,
        law: law.into(),
        telemetry_hz: hz,
        interrupt: &interrupt,
        progress: &mut progress,
    };
    let outcome = record::run(&mut client, &mut plan);
    bar.finish_and_clear();
    let recording = outcome?;
    let mut files = recording.write(out)?;
    // Figures of a run cut short are drawn as far as it went, if they can be.
    if recording.complete() {
        files.extend(write_figures(out, &scenario, &recording)?);
    } else if !recording.trace.is_empty() {
        match write_figures(out, &scenario, &recording) {
            Ok(figures) => files.extend(figures),
            Err(e) => eprintln!(
                "note: no figures of the part recorded: {}",
                station::causes_text(e.chain())
            ),
        }
    }
    let s = &recording.summary;
    say!(
        "{} with the {} law on {}: {:.1} s recorded in {:.1} s ({} trace rows), ended by {}",
        s.scenario,
        s.law,
        s.source,
        s.sim_time_s,
        s.wall_time_s,
        recording.trace.len(),
        recording.ended_by
    );
    let window = record::final_window_text(s.sim_time_s);
    let line = |which: &str, e: &ErrorReport| {
        format!(
            "  {which}: settle {}, final {:.4} m / {:+.2}°, {window}: RMS {:.4} m, max {:.4} m",
            settle_text(e.settle_time_s),
            e.final_position_error_m,
            e.final_heading_error_rad.to_degrees(),
            e.rms_position_error_m,
            e.max_position_error_m
        )
    };
    if recording.report.is_some() {
        if let Some(t) = &s.true_error {
            say!("{}", line("true error (ground truth)", t));
        }
        say!(
            "{}",
            line("estimated error (robot's odometry)", &s.estimated_error)
        );
    } else {
        say!("  errors: none, the robot's run report did not come");
    }
    say!(
        "  supervisor: {}{}",
        s.supervisor.final_state,
        if s.supervisor.faults.is_empty() {
            String::new()
        } else {
            format!(", faults {}", s.supervisor.faults.join(", "))
        }
    );
    say!("  {}", recording.telemetry.text());
    if let Some(warning) = recording.telemetry.warning() {
        eprintln!("warning: {warning}");
    }
    let names: Vec<String> = files
        .iter()
        .filter_map(|f| f.file_name())
        .map(|n| n.to_string_lossy().into_owned())
        .collect();
    say!("  wrote {} to {}", names.join(", "), out.display());
    if !recording.complete() {
        return Err(NotAsAsked(format!(
            "the run did not end at its time limit: it ended by {}; what was recorded is in \
{} (summary.json: \"complete\": false)",
            recording.ended_by,
            out.display()
        ))
        .into());
    }
    if let Some(e) = &recording.after_run_error {
        bail!("the link failed after the run: {e}");
    }
    Ok(())
}

/// Writes Figs. 5–7 of `recording`, a run of `scenario`, into `out` (which exists): from
/// the ground truth when the robot sent it, else from its odometry, titled so (its
/// `trace.csv` keeps the true columns empty). Returns the files written.
#[cfg(feature = "figures")]
fn write_figures(out: &FsPath, scenario: &Scenario, recording: &Recording) -> Result<Vec<PathBuf>> {
    use robot_files::figures::write_run_figures;
    let summary = &recording.summary;
    if recording.has_truth {
        return Ok(write_run_figures(out, scenario, summary, &recording.trace)?);
    }
    let mut shown = scenario.clone();
    shown.name = format!("{} (robot's odometry, no ground truth)", scenario.name);
    let as_truth = record::estimate_as_truth(&recording.trace);
    Ok(write_run_figures(out, &shown, summary, &as_truth)?)
}

/// A station built without its `figures` feature draws no figures; it says so.
#[cfg(not(feature = "figures"))]
fn write_figures(_: &FsPath, _: &Scenario, _: &Recording) -> Result<Vec<PathBuf>> {
    eprintln!("note: no figures (this station was built without its `figures` feature)");
    Ok(Vec::new())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let link = &cli.link;
    let result = match cli.command {
        Command::Ports => (|| {
            let ports = transport::ports().context("listing serial ports")?;
            if ports.is_empty() {
                say!("no serial ports found");
            }
            for (name, kind) in ports {
                say!("{name:<24} {kind}");
            }
            Ok(())
        })(),
        Command::Info => cmd_info(link),
        Command::Params(c) => cmd_params(link, c),
        Command::Path(PathCommand::Upload { scenario, law }) => cmd_upload(link, &scenario, law),
        Command::Arm { hz } => cmd_arm(link, hz),
        Command::Tune { timeout_s } => cmd_tune(link, timeout_s),
        Command::Disarm => cmd_simple(link, Request::Disarm, "disarmed"),
        Command::Estop => cmd_simple(link, Request::EmergencyStop, "emergency stop latched"),
        Command::ClearFaults => cmd_simple(link, Request::ClearFaults, "faults cleared"),
        Command::Stats => cmd_stats(link),
        Command::Watch { hz } => cmd_watch(link, hz),
        Command::Record {
            out,
            hz,
            duration_s,
        } => cmd_record(link, &out, hz, duration_s),
        Command::Run {
            scenario,
            law,
            out,
            hz,
        } => cmd_run(link, &scenario, law, &out, hz),
        Command::Calibrate(args) => calibrate::command(link_open(link), &args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let broken_pipe = e
                .downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe);
            if broken_pipe {
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {}", station::causes_text(e.chain()));
            if e.downcast_ref::<NotAsAsked>().is_some() {
                ExitCode::from(EXIT_NOT_AS_ASKED)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

fn link_open(link: &LinkArgs) -> Result<Client<Box<dyn Transport>>> {
    open(link)
}
