//! `station drive`: keyboard teleop in the terminal, in the robot's velocity mode (the
//! keys are [`station::teleop`]'s).
//!
//! It arms the velocity mode, streams the command every 50 ms and heartbeats paced by the
//! robot's own step counter, prints the robot's events, and on `q`, Esc or Ctrl-C sends a
//! zero command and disarms. The terminal is put in raw mode (keys arrive one by one,
//! Ctrl-C as a key) and restored on every way out. Without a terminal on stdin there are
//! no keys: it refuses before it connects.

use std::io::{IsTerminal as _, Write as _};
use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use crossterm::event::{self, Event, KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use crossterm::terminal;
use link::{ArmMode, Request, Uplink};
use station::record;
use station::teleop::{Teleop, TeleopKey, COMMAND_PERIOD};

use crate::{open, LinkArgs};

/// The terminal in raw mode for as long as this lives.
struct RawMode;

impl RawMode {
    fn enter() -> Result<Self> {
        terminal::enable_raw_mode()?;
        Ok(Self)
    }
}

impl Drop for RawMode {
    fn drop(&mut self) {
        let _ = terminal::disable_raw_mode();
    }
}

/// The teleop key of a terminal key event (`None`: not one, or a release).
fn teleop_key(key: KeyEvent) -> Option<TeleopKey> {
    if key.kind == KeyEventKind::Release {
        return None;
    }
    match key.code {
        KeyCode::Up => Some(TeleopKey::Faster),
        KeyCode::Down => Some(TeleopKey::Slower),
        KeyCode::Left => Some(TeleopKey::Left),
        KeyCode::Right => Some(TeleopKey::Right),
        KeyCode::Esc => Some(TeleopKey::Quit),
        KeyCode::Char('c') if key.modifiers.contains(KeyModifiers::CONTROL) => {
            Some(TeleopKey::Quit)
        }
        KeyCode::Char(c) => TeleopKey::of_char(c),
        _ => None,
    }
}

/// Arms the velocity mode and drives it from the keyboard until `q` (or the robot stops
/// on its own: a fault, the button); disarms on the way out.
pub(crate) fn cmd_drive(link: &LinkArgs) -> Result<()> {
    if !std::io::stdin().is_terminal() {
        bail!(
            "station drive reads the keyboard: stdin is not a terminal (run it in a terminal, \
             not from a pipe or a script)"
        );
    }
    let mut client = open(link)?;
    let params = station::ops::get_params(&mut client)?;
    let mut teleop = Teleop::new(&params.robot.velocity);
    record::set_telemetry_rate(&mut client, 10)?;
    client.command(Request::Arm {
        mode: ArmMode::FollowVelocity,
        initial_motion: None,
        run_time_limit_steps: None,
    })?;
    let driven = {
        let _raw = RawMode::enter()?;
        drive_loop(
            &mut client,
            &mut teleop,
            record::HeartbeatPacer::new(params.supervisor.heartbeat_timeout_steps),
        )
    };
    // Stop, then disarm, whatever ended the loop.
    let _ = client.send_only(Request::Velocity {
        v_m_s: 0.0,
        omega_rad_s: 0.0,
    });
    let disarmed = client.command(Request::Disarm);
    let _ = client.request(Request::SetTelemetryRate { hz: 1 });
    println!();
    let ended = driven?;
    disarmed?;
    println!("{ended}; disarmed");
    Ok(())
}

/// The loop under raw mode: keys, the command every [`COMMAND_PERIOD`], heartbeats, the
/// robot's events. Returns what ended it.
fn drive_loop(
    client: &mut station::client::Client<Box<dyn station::transport::Transport>>,
    teleop: &mut Teleop,
    mut heartbeat: record::HeartbeatPacer,
) -> Result<String> {
    let mut robot_step = None;
    let mut next_command = Instant::now();
    let mut out = std::io::stdout();
    loop {
        while event::poll(Duration::ZERO)? {
            if let Event::Key(key) = event::read()? {
                if let Some(key) = teleop_key(key) {
                    if !teleop.press(key) {
                        return Ok("quit".to_string());
                    }
                }
            }
        }
        if Instant::now() >= next_command {
            let c = teleop.command();
            client.send_only(Request::Velocity {
                v_m_s: c.v_m_s,
                omega_rad_s: c.omega_rad_s,
            })?;
            next_command += COMMAND_PERIOD;
            write!(out, "\r{}\x1b[K", teleop.status())?;
            out.flush()?;
        }
        if heartbeat.due(robot_step) {
            client.send_only(Request::Heartbeat)?;
        }
        match client.next_message(Duration::from_millis(10))? {
            Some(Uplink::Telemetry(frame)) => robot_step = Some(frame.step),
            Some(Uplink::Event { step, event }) => {
                write!(out, "\r\x1b[Kstep {step}: {event:?}\r\n")?;
                if matches!(
                    event,
                    controller_core::supervisor::Event::Disarmed(_)
                        | controller_core::supervisor::Event::Faulted
                ) {
                    return Ok(format!("the robot stopped ({event:?})"));
                }
            }
            _ => {}
        }
    }
}
