//! A minimal ground station on the runtime link, for driving a processor-in-the-loop run
//! without the full station: configure, upload the scenario's path, arm (in motion, or in
//! the velocity mode), then send what the plant loop hands it, and count what comes back.
//!
//! It speaks to any TCP endpoint that carries the link (`host-sim pil`'s station port,
//! or a serial bridge to a robot). Until armed, requests are sent one at a time and each
//! waits for its reply (matched by `seq`); a reply that does not come is re-sent (every
//! request is safe to repeat).
//!
//! **After arming, requests go in step with the plant.** A lockstep run goes at whatever
//! pace the emulator manages, so a request sent at a wall-clock moment would reach the
//! firmware at an unknown control step. Instead the plant loop hands the station, through
//! [`StepRequests`], the request a control step is to take (a heartbeat, a velocity
//! command of the scenario's timeline) before it sends that step's sensors, and waits:
//! the station sends it, then a `Ping`, and reports back when the `Pong` comes. The link
//! service handles requests in order, so by then the request waits in the control side's
//! queue, and the step the plant sends next takes it: the run is the same computation
//! as `host-sim run`, whose commands arrive at their steps. The request's own reply, sent
//! by that step, is read later; a refusal among them is reported.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context as _, Result};
use controller_core::kinematics::{BodyVelocity, Pose};
use controller_core::law::LawKind;
use controller_core::path::Path;
use controller_core::reference::ReferenceMode;
use controller_core::supervisor::Event;
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
    /// How to arm: following the path, or in the velocity mode (the scenario has a
    /// `[velocity]` timeline, whose commands the plant loop hands over in step).
    pub mode_armed: ArmMode,
    /// Telemetry rate to ask for, Hz.
    pub telemetry_hz: u8,
}

impl StationScript {
    /// The script for `scenario` followed with `law`: its robot and supervisor settings,
    /// its path and reference, its start pose and motion, the velocity mode if it has a
    /// timeline; telemetry at 20 Hz.
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
            mode_armed: match scenario.velocity {
                Some(_) => ArmMode::FollowVelocity,
                None => ArmMode::FollowPath,
            },
            telemetry_hz: 20,
        }
    }
}

/// The plant loop's end of the station (module doc): hands over the request the coming
/// control step is to take.
pub struct StepRequests {
    to_station: Sender<Request>,
    passed_on: Receiver<Result<(), String>>,
}

impl StepRequests {
    /// Sends `request` through the station and returns once the firmware's link service
    /// has passed it to the control side, so that the next control step takes it; the
    /// station's error otherwise (the station stopped, or no `Pong` came).
    pub fn send(&self, request: Request) -> Result<(), String> {
        self.to_station
            .send(request)
            .map_err(|_| "the built-in station has stopped".to_string())?;
        self.passed_on
            .recv()
            .map_err(|_| "the built-in station has stopped".to_string())?
    }
}

/// The station's end of [`StepRequests`].
pub struct StepInbox {
    from_loop: Receiver<Request>,
    passed_on: Sender<Result<(), String>>,
}

impl StepInbox {
    /// For tests: plays the station, answering every request handed over as passed on,
    /// until the plant loop's end is dropped; the requests, in order.
    #[cfg(test)]
    pub(super) fn pass_everything_on(&self) -> Vec<Request> {
        let mut seen = Vec::new();
        while let Ok(request) = self.from_loop.recv() {
            seen.push(request);
            if self.passed_on.send(Ok(())).is_err() {
                break;
            }
        }
        seen
    }
}

/// A connected pair: the plant loop's [`StepRequests`], the station's [`StepInbox`].
pub fn step_requests() -> (StepRequests, StepInbox) {
    let (to_station, from_loop) = channel();
    let (passed_on_tx, passed_on) = channel();
    (
        StepRequests {
            to_station,
            passed_on,
        },
        StepInbox {
            from_loop,
            passed_on: passed_on_tx,
        },
    )
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
    /// Velocity commands sent.
    pub velocity_commands: u32,
    /// Requests sent in step that the robot refused, as text (module doc).
    pub refused_in_step: Vec<String>,
    /// Velocity commands of the timeline refused after the robot reported a fault or a
    /// disarm: the answer it owes them then (the simulator's own run hands its timeline
    /// on the same way), so not counted among [`Self::refused_in_step`].
    pub velocity_refused_after_stop: u32,
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
    /// Requests sent in step whose replies have not come yet: `seq` and name.
    in_step: Vec<(u16, &'static str)>,
    /// The other end closed the connection.
    closed: bool,
    /// The robot reported a fault or a disarm (its later velocity commands are refused).
    stopped: bool,
}

/// Runs `script` against the link at `addr`, then sends what comes through `inbox` in
/// step (module doc) until `stop` is set, the plant loop drops its end or the link
/// closes.
pub fn drive(
    addr: SocketAddr,
    script: &StationScript,
    inbox: &StepInbox,
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
        in_step: Vec::new(),
        closed: false,
        stopped: false,
    };
    session.configure(script)?;
    session.serve_in_step(inbox, stop)?;
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
            mode: script.mode_armed,
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

    /// Reads until `stop` (or the plant loop or the link ends), sending what the plant
    /// loop hands over in step and telling it when the firmware has passed it on.
    fn serve_in_step(&mut self, inbox: &StepInbox, stop: &AtomicBool) -> Result<()> {
        // Short reads: the plant loop waits on each request handed over.
        self.stream
            .set_read_timeout(Some(Duration::from_millis(1)))?;
        while !stop.load(Ordering::Relaxed) {
            match inbox.from_loop.try_recv() {
                Ok(request) => {
                    let passed_on = self.pass_on(request).map_err(|e| format!("{e:#}"));
                    if inbox.passed_on.send(passed_on).is_err() {
                        return Ok(());
                    }
                }
                Err(TryRecvError::Empty) => {
                    self.poll()?;
                    if self.closed {
                        return Ok(());
                    }
                }
                Err(TryRecvError::Disconnected) => return Ok(()),
            }
        }
        Ok(())
    }

    /// Sends `request` without waiting for its reply, then a `Ping`, and waits for the
    /// `Pong`: the link service has then passed `request` on (module doc).
    fn pass_on(&mut self, request: Request) -> Result<()> {
        match request {
            Request::Heartbeat => self.report.heartbeats += 1,
            Request::Velocity { .. } => self.report.velocity_commands += 1,
            _ => {}
        }
        self.seq = self.seq.wrapping_add(1);
        self.in_step.push((self.seq, request.name()));
        self.send(&Downlink {
            seq: self.seq,
            request,
        })?;
        let nonce = u32::from(self.seq);
        match self.request(Request::Ping { nonce })? {
            Ok(Reply::Pong { nonce: n }) if n == nonce => Ok(()),
            other => bail!("Ping: {}", describe(&other)),
        }
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
                }
                Ok(Received::Message(Uplink::Reply { seq, result }))
                    if self.in_step.iter().any(|&(s, _)| s == seq) =>
                {
                    self.answered_in_step(seq, &result);
                }
                Ok(Received::Message(Uplink::Event { step, event })) => {
                    self.stopped |= matches!(event, Event::Faulted | Event::Disarmed(_));
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

impl Session {
    /// Counts the reply to a request sent in step; a refusal is kept as text.
    fn answered_in_step(&mut self, seq: u16, result: &Result<Reply, Refusal>) {
        let Some(at) = self.in_step.iter().position(|&(s, _)| s == seq) else {
            return;
        };
        let (_, name) = self.in_step.swap_remove(at);
        self.report.replies += 1;
        if result.is_err() && self.stopped && name == "Velocity" {
            self.report.velocity_refused_after_stop += 1;
        } else if let Err(refusal) = result {
            self.report
                .refused_in_step
                .push(format!("{name} (seq {seq}): {refusal}"));
        }
    }
}

/// A reply or refusal as text.
fn describe(result: &Result<Reply, Refusal>) -> String {
    match result {
        Ok(reply) => format!("unexpected reply {reply:?}"),
        Err(refusal) => format!("refused: {refusal}"),
    }
}
