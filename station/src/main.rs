//! `station`: drive the robot (serial) or the virtual robot (TCP) from a terminal.
//! `station --help` lists the commands.

use std::io::Write as _;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use clap::Parser;
use link::{Reply, Request};
use robot_files::cli::Law;
use robot_files::scenario::Scenario;
use station::client::Client;
use station::transport::{self, Serial, Tcp, Transport};
use station::{calibrate, ops, NotAsAsked, EXIT_NOT_AS_ASKED};

/// `println!` that returns an error instead of panicking when stdout is closed.
macro_rules! say {
    ($($arg:tt)*) => {{
        writeln!(std::io::stdout(), $($arg)*)?
    }};
}

mod cli_args;
mod drive;
mod live;
mod recording;

use crate::cli_args::{Cli, Command, LinkArgs, ParamsCommand, PathCommand};

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
    let failure = ops::panic_record(&mut client)?;
    let link = client.transport().describe();
    write!(
        std::io::stdout(),
        "{}",
        ops::describe_robot(&info, failure.as_ref(), &link)
    )?;
    // Shown: the robot may forget it.
    if failure.is_some() {
        ops::clear_panic_record(&mut client)?;
    }
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
                ops::persist_params(&mut client)?;
                say!("parameters saved in the robot's flash");
            }
        }
        ParamsCommand::Persist => {
            ops::persist_params(&mut client)?;
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
        Command::Arm { hz } => live::cmd_arm(link, hz),
        Command::Drive => drive::cmd_drive(link),
        Command::Tune { timeout_s } => cmd_tune(link, timeout_s),
        Command::Pose {
            x_m,
            y_m,
            theta_rad,
        } => cmd_simple(
            link,
            Request::SetPose {
                x_m,
                y_m,
                theta_rad,
            },
            &format!("pose set: ({x_m} m, {y_m} m, {theta_rad} rad)"),
        ),
        Command::Disarm => cmd_simple(link, Request::Disarm, "disarmed"),
        Command::Estop => cmd_simple(link, Request::EmergencyStop, "emergency stop latched"),
        Command::ClearFaults => cmd_simple(link, Request::ClearFaults, "faults cleared"),
        Command::Stats => cmd_stats(link),
        Command::Watch { hz, foxglove } => live::cmd_watch(link, hz, foxglove.as_deref()),
        Command::Record {
            out,
            hz,
            duration_s,
            mcap,
        } => recording::cmd_record(link, &out, hz, duration_s, mcap.as_deref()),
        Command::Run {
            scenario,
            law,
            out,
            hz,
            mcap,
        } => recording::cmd_run(link, &scenario, law, &out, hz, mcap.as_deref()),
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
