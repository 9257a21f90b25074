//! A minimal ground station on the runtime link, for driving a processor-in-the-loop run
//! without the full station: configure, upload the scenario's path, arm in motion, keep
//! the heartbeat up and count what comes back.
//!
//! It speaks to any TCP endpoint that carries the link (`host-sim pil`'s station port,
//! or a serial bridge to a robot). Requests are sent one at a time and each waits for
//! its reply (matched by `seq`); a reply that does not come is re-sent (every request is
//! safe to repeat).
//!
//! **Heartbeats follow the robot's time, not the wall clock.** The robot counts its
//! heartbeat timeout in control steps, and a lockstep run goes at whatever pace the
//! emulator manages, so a wall-clock heartbeat would be early or late by the run's speed.
//! This station sends one heartbeat for every [`StationScript::heartbeat_every`]
//! telemetry frames, which the robot emits at a rate in its own steps.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context as _, Result};
use controller_core::kinematics::{BodyVelocity, Pose};
use controller_core::law::LawKind;
use controller_core::path::Path;
use controller_core::reference::ReferenceMode;
use link::upload::chunks;
use link::{
    encode, path_checksum, ArmMode, Decoder, Downlink, ParamSet, PathBegin, PathCommit, ProtocolId,
    Received, Refusal, Reply, Request, Uplink, MAX_FRAME_LEN,
};

use robot_files::scenario::Scenario;

/// How long one request waits for its reply before it is sent again.
const REPLY_TIMEOUT: Duration = Duration::from_secs(5);
/// Times a request is sent before the station gives up.
const ATTEMPTS: usize = 4;

/// What the station does, in order.
#[derive(Clone, Debug)]
pub struct StationScript {
    /// The configuration to set (`SetParams`).
    pub params: ParamSet,
    /// The path to upload.
    pub path: Path,
    /// Its reference speed, m/s.
    pub speed_m_s: f32,
    /// How the reference moves along it.
    pub mode: ReferenceMode,
    /// The steering law.
    pub law: LawKind,
    /// Where the robot starts (world frame, m and rad).
    pub start_pose: Pose,
    /// "Arm in motion": the body velocity (m/s, rad/s) the robot already has.
    pub initial_motion: Option<BodyVelocity>,
    /// Telemetry rate to ask for, Hz.
    pub telemetry_hz: u8,
    /// One heartbeat per this many telemetry frames (module doc).
    pub heartbeat_every: u32,
}

impl StationScript {
    /// The script for `scenario` followed with `law`: its robot and supervisor settings,
    /// its path and reference, its start pose and motion; telemetry at 20 Hz, a heartbeat
    /// per telemetry frame (every 50 control steps at 1 kHz, a tenth of the default
    /// heartbeat timeout).
    pub fn for_scenario(scenario: &Scenario, law: LawKind) -> Self {
        let s = scenario.start;
        let moving = s.v_m_s != 0.0 || s.omega_rad_s != 0.0;
        Self {
            params: ParamSet {
                robot: scenario.robot,
                supervisor: scenario.supervisor,
            },
            path: scenario.path.clone(),
            speed_m_s: scenario.reference_speed_m_s,
            mode: scenario.reference_mode,
            law,
            start_pose: Pose::new(s.x_m as f32, s.y_m as f32, s.theta_rad as f32),
            initial_motion: moving.then(|| BodyVelocity::new(s.v_m_s as f32, s.omega_rad_s as f32)),
            telemetry_hz: 20,
            heartbeat_every: 1,
        }
    }
}

/// What the station saw.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StationReport {
    /// The robot's name and chip, from `Info`.
    pub robot: String,
    /// Requests answered as expected.
    pub replies: u32,
    /// Requests sent again because their reply did not come.
    pub resent: u32,
    /// Telemetry frames received.
    pub telemetry_frames: u32,
    /// Heartbeats sent.
    pub heartbeats: u32,
    /// Events received, as text.
    pub events: Vec<String>,
    /// The robot's last telemetry step.
    pub last_telemetry_step: Option<u32>,
}

/// The station's side of one connection.
struct Session {
    stream: TcpStream,
    decoder: Decoder,
    seq: u16,
    report: StationReport,
    /// Heartbeats owed (telemetry frames seen since the last one).
    since_heartbeat: u32,
    heartbeat_every: u32,
    /// The other end closed the connection.
    closed: bool,
}

/// Runs `script` against the link at `addr`, then keeps the heartbeat up until `stop`
/// is set or the link closes.
pub fn drive(
    addr: SocketAddr,
    script: &StationScript,
    stop: &Arc<AtomicBool>,
) -> Result<StationReport> {
    let stream = connect(addr, stop)?;
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(Duration::from_millis(20)))?;
    let mut session = Session {
        stream,
        decoder: Decoder::new(),
        seq: 0,
        report: StationReport::default(),
        since_heartbeat: 0,
        heartbeat_every: script.heartbeat_every.max(1),
        closed: false,
    };
    session.configure(script)?;
    session.keep_alive(stop)?;
    Ok(session.report)
}

/// Connects, retrying while the port is not yet open (until `stop`).
fn connect(addr: SocketAddr, stop: &AtomicBool) -> Result<TcpStream> {
    let started = Instant::now();
    loop {
        match TcpStream::connect(addr) {
            Ok(stream) => return Ok(stream),
            Err(e)
                if started.elapsed() < Duration::from_secs(30) && !stop.load(Ordering::Relaxed) =>
            {
                let _ = e;
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => return Err(e).with_context(|| format!("connecting to the link at {addr}")),
        }
    }
}

impl Session {
    /// Who is there, the configuration, the path, the telemetry rate, arming.
    fn configure(&mut self, script: &StationScript) -> Result<()> {
        match self.request(Request::Info)? {
            Ok(Reply::Info(info)) => {
                ensure!(
                    info.protocol == ProtocolId::OURS,
                    "the robot speaks {}, this station {}",
                    info.protocol,
                    ProtocolId::OURS
                );
                self.report.robot = format!("{} on {}", info.robot_name, info.chip);
            }
            other => bail!("Info: unexpected answer {other:?}"),
        }
        match self.request(Request::SetParams(script.params))? {
            Ok(Reply::ParamsApplied { params_hash }) => ensure!(
                params_hash == link::params_hash(&script.params),
                "SetParams: the robot applied another configuration"
            ),
            other => bail!("SetParams: {}", describe(&other)),
        }
        self.upload(script)?;
        match self.request(Request::SetTelemetryRate {
            hz: script.telemetry_hz,
        })? {
            Ok(Reply::Ack) => {}
            other => bail!("SetTelemetryRate: {}", describe(&other)),
        }
        // The pose command, as `station run` sends it: the robot starts from the start pose.
        let pose = script.start_pose;
        match self.request(Request::SetPose {
            x_m: pose.x_m,
            y_m: pose.y_m,
            theta_rad: pose.theta_rad,
        })? {
            Ok(Reply::Ack) => {}
            other => bail!("SetPose: {}", describe(&other)),
        }
        match self.request(Request::Arm {
            mode: ArmMode::FollowPath,
            initial_motion: script.initial_motion,
            run_time_limit_steps: None,
        })? {
            Ok(Reply::Ack) => Ok(()),
            other => bail!("Arm: {}", describe(&other)),
        }
    }

    /// Begin, every chunk, commit.
    fn upload(&mut self, script: &StationScript) -> Result<()> {
        const UPLOAD: u16 = 1;
        let segments = script.path.segments();
        let count = u8::try_from(segments.len()).context("too many segments")?;
        let begin = PathBegin {
            upload_id: UPLOAD,
            segment_count: count,
            speed_m_s: script.speed_m_s,
            mode: script.mode,
            law: script.law,
            start_pose: script.start_pose,
        };
        match self.request(Request::PathBegin(begin))? {
            Ok(Reply::Ack) => {}
            other => bail!("PathBegin: {}", describe(&other)),
        }
        for chunk in chunks(UPLOAD, segments) {
            match self.request(Request::PathChunk(chunk))? {
                Ok(Reply::PathChunkStored { .. }) => {}
                other => bail!("PathChunk: {}", describe(&other)),
            }
        }
        let commit = PathCommit {
            upload_id: UPLOAD,
            segment_count: count,
            checksum: path_checksum(segments),
        };
        match self.request(Request::PathCommit(commit))? {
            Ok(Reply::PathCommitted(summary)) => {
                ensure!(
                    summary.checksum == commit.checksum,
                    "PathCommit: the robot committed another path"
                );
                Ok(())
            }
            other => bail!("PathCommit: {}", describe(&other)),
        }
    }

    /// Reads until `stop`, sending a heartbeat as telemetry frames come in.
    fn keep_alive(&mut self, stop: &AtomicBool) -> Result<()> {
        while !stop.load(Ordering::Relaxed) {
            if self.poll()?.is_none() && self.closed {
                return Ok(());
            }
            if self.since_heartbeat >= self.heartbeat_every {
                self.since_heartbeat = 0;
                self.seq = self.seq.wrapping_add(1);
                self.send(&Downlink {
                    seq: self.seq,
                    request: Request::Heartbeat,
                })?;
                self.report.heartbeats += 1;
            }
        }
        Ok(())
    }
}

impl Session {
    /// Sends `request` until its reply comes (or [`ATTEMPTS`] times); the reply.
    ///
    /// Every attempt carries the same `seq`, as `station`'s client does: a reply that comes
    /// late answers the attempt still waiting, and the robot handles a repeat as a repeat
    /// (a fresh `seq` would make a late `Arm` look refused as "already armed").
    fn request(&mut self, request: Request) -> Result<Result<Reply, Refusal>> {
        self.seq = self.seq.wrapping_add(1);
        let seq = self.seq;
        for attempt in 0..ATTEMPTS {
            if attempt > 0 {
                self.report.resent += 1;
            }
            self.send(&Downlink {
                seq,
                request: request.clone(),
            })?;
            let deadline = Instant::now() + REPLY_TIMEOUT;
            while Instant::now() < deadline {
                if let Some(Uplink::Reply { seq: s, result }) = self.poll()? {
                    if s == seq {
                        self.report.replies += 1;
                        return Ok(result);
                    }
                }
                if self.closed {
                    bail!(
                        "the link closed while waiting for the reply to {}",
                        request.name()
                    );
                }
            }
        }
        bail!("no reply to {} after {ATTEMPTS} attempts", request.name())
    }

    fn send(&mut self, message: &Downlink) -> Result<()> {
        let mut frame = [0u8; MAX_FRAME_LEN];
        let len = encode(message, &mut frame)?;
        self.stream
            .write_all(&frame[..len])
            .context("writing to the link")
    }

    /// Reads what has arrived (waits up to the read timeout) and returns the first reply
    /// among it, if any; telemetry and events are recorded on the way.
    fn poll(&mut self) -> Result<Option<Uplink>> {
        let mut bytes = [0u8; 512];
        let n = match self.stream.read(&mut bytes) {
            Ok(0) => {
                self.closed = true;
                return Ok(None);
            }
            Ok(n) => n,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                return Ok(None)
            }
            Err(e) => return Err(e).context("reading from the link"),
        };
        let mut reply = None;
        let received: Vec<_> = self.decoder.feed::<Uplink>(&bytes[..n]).collect();
        for outcome in received {
            match outcome {
                Ok(Received::Message(Uplink::Telemetry(frame))) => {
                    self.report.telemetry_frames += 1;
                    self.report.last_telemetry_step = Some(frame.step);
                    self.since_heartbeat += 1;
                }
                Ok(Received::Message(Uplink::Event { step, event })) => {
                    self.report.events.push(format!("step {step}: {event:?}"));
                }
                Ok(Received::Message(message @ Uplink::Reply { .. })) if reply.is_none() => {
                    reply = Some(message);
                }
                Ok(Received::Mismatch(id)) => {
                    bail!("the robot speaks {id}, this station {}", ProtocolId::OURS)
                }
                _ => {}
            }
        }
        Ok(reply)
    }
}

/// A reply or refusal as text.
fn describe(result: &Result<Reply, Refusal>) -> String {
    match result {
        Ok(reply) => format!("unexpected reply {reply:?}"),
        Err(refusal) => format!("refused: {refusal}"),
    }
}
