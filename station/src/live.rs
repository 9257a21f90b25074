//! The live view: `watch`, and `arm`, which keeps the robot armed under it.

use std::io::{IsTerminal as _, Write as _};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Result;
use link::{Request, Uplink};
use station::record;
use station::transport::Transport;
use station::{ops, watch};

use station::foxglove::FoxgloveStream;

use crate::{interrupt_flag, open, LinkArgs};

/// The live view of the telemetry at `hz` until Ctrl-C, also streamed to Foxglove on
/// `foxglove` (`HOST:PORT`) if given.
pub(crate) fn cmd_watch(link: &LinkArgs, hz: u8, foxglove: Option<&str>) -> Result<()> {
    let mut client = open(link)?;
    let mut stream = match foxglove {
        Some(address) => {
            let params = ops::get_params(&mut client)?;
            let stream = FoxgloveStream::start(address, &params)?;
            eprintln!(
                "foxglove live on ws://{} (subprotocol foxglove.sdk.v1)",
                stream.address(address)
            );
            Some(stream)
        }
        None => None,
    };
    live_view(&mut client, hz, None, stream.as_mut())
}

/// Arms, then holds the robot armed with heartbeats under the live view until it stops on
/// its own (disarm, fault, end of run) or Ctrl-C, which disarms before returning.
pub(crate) fn cmd_arm(link: &LinkArgs, hz: u8) -> Result<()> {
    let mut client = open(link)?;
    let timeout = ops::get_params(&mut client)?
        .supervisor
        .heartbeat_timeout_steps;
    ops::arm(&mut client, None, None)?;
    let held = live_view(
        &mut client,
        hz,
        Some(record::HeartbeatPacer::new(timeout)),
        None,
    );
    let disarmed = client.command(Request::Disarm);
    held?;
    disarmed?;
    say!("disarmed");
    Ok(())
}

/// The live view of the telemetry until Ctrl-C; with a `heartbeat` pacer, also the
/// heartbeats that keep a link-armed robot armed, until the robot leaves the armed state;
/// with a Foxglove `stream`, every frame streamed and the parameter changes its clients
/// ask for applied.
fn live_view(
    client: &mut station::client::Client<Box<dyn Transport>>,
    hz: u8,
    mut heartbeat: Option<record::HeartbeatPacer>,
    mut stream: Option<&mut FoxgloveStream>,
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
        if let Some(stream) = stream.as_deref_mut() {
            stream.frame(&frame, truth.as_ref(), rate);
            stream.parameters(client, frame.state)?;
        }
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
