//! The station's requests, one function each: who the robot is, its parameters (through
//! the robot-file code of `robot_files`), path upload from a scenario, arming.

use controller_core::kinematics::{BodyVelocity, Pose};
use controller_core::law::LawKind;
use controller_core::path::Path;
use controller_core::reference::ReferenceMode;
use controller_core::supervisor::{DisarmReason, Event, ResetCause};
use std::time::Duration;

use link::{
    path_checksum, upload, ArmMode, BrownOutReset, CommitSummary, PanicReport, ParamSet, PathBegin,
    PathCommit, Reply, Request, RobotInfo, TuneReport, Uplink, PERSIST_REPLY_TIMEOUT_MS,
};
use robot_app::stm32f4::option_bytes::BorLevel;
use robot_files::robot_file::{tuned_wheel_sections, RobotFile, SectionError};
use robot_files::scenario::Scenario;

use crate::client::{Client, StationError};
use crate::transport::Transport;

/// Why a robot file could not be applied.
#[derive(Debug, thiserror::Error)]
pub enum ParamsError {
    /// The file names a bad key or value.
    #[error("{file}: {error}")]
    File {
        /// The file's name.
        file: String,
        /// The key and what is wrong.
        error: SectionError,
    },
    /// The link failed or the robot refused.
    #[error(transparent)]
    Link(#[from] StationError),
}

fn unexpected(request: &'static str, reply: Reply) -> StationError {
    StationError::Unexpected {
        request,
        reply: format!("{reply:?}"),
    }
}

/// Who the robot is.
pub fn info<T: Transport>(client: &mut Client<T>) -> Result<RobotInfo, StationError> {
    match client.request(Request::Info)? {
        Reply::Info(info) => Ok(info),
        other => Err(unexpected("Info", other)),
    }
}

/// The robot's active configuration.
pub fn get_params<T: Transport>(client: &mut Client<T>) -> Result<ParamSet, StationError> {
    match client.request(Request::GetParams)? {
        Reply::Params(set) => Ok(set),
        other => Err(unexpected("GetParams", other)),
    }
}

/// The robot's configuration as a robot file (`[robot]` and `[supervisor]`, every key),
/// without the sections that hold no key.
pub fn params_to_toml(set: &ParamSet) -> String {
    without_empty_sections(&RobotFile::of(&set.robot, &set.supervisor).to_toml())
}

/// `toml` without its empty sections: a `[header]` followed by no key before the next
/// header or the end goes, with the blank and comment lines after it.
fn without_empty_sections(toml: &str) -> String {
    let mut out = String::new();
    let mut section = String::new();
    let mut has_key = true;
    for line in toml.split_inclusive('\n') {
        let trimmed = line.trim();
        if trimmed.starts_with('[') {
            if has_key {
                out.push_str(&section);
            }
            section.clear();
            has_key = false;
        } else if !trimmed.is_empty() && !trimmed.starts_with('#') {
            has_key = true;
        }
        section.push_str(line);
    }
    if has_key {
        out.push_str(&section);
    }
    out
}

/// The configuration `text` (a robot file named `file`) describes, over `current` (the
/// robot's): keys the file leaves out keep the robot's values; the path-derived checks
/// (`divergence`, `geofence_radius_m`) left at "auto" keep the robot's, which it derives
/// again from each committed path. Errors name the key.
pub fn params_from_toml(
    text: &str,
    file: &str,
    current: &ParamSet,
) -> Result<ParamSet, ParamsError> {
    let named = |error| ParamsError::File {
        file: file.to_string(),
        error,
    };
    let parsed = RobotFile::from_toml(text).map_err(named)?;
    let (robot, supervisor) = parsed
        .over(&current.robot, &current.supervisor)
        .map_err(named)?;
    Ok(ParamSet { robot, supervisor })
}

/// Sends `set`; returns the robot's hash of the configuration it now runs.
pub fn set_params<T: Transport>(
    client: &mut Client<T>,
    set: ParamSet,
) -> Result<u32, StationError> {
    match client.request(Request::SetParams(set))? {
        Reply::ParamsApplied { params_hash } => Ok(params_hash),
        other => Err(unexpected("SetParams", other)),
    }
}

/// Saves the robot's configuration in its flash. Sent once, and the reply awaited
/// [`PERSIST_REPLY_TIMEOUT_MS`]: the erase stalls the robot for up to 2 s, and a request
/// sent again meanwhile would only be lost in the stall (the robot answers a repeat with
/// the reply it kept, never with a second erase).
pub fn persist_params<T: Transport>(client: &mut Client<T>) -> Result<(), StationError> {
    let wait = Duration::from_millis(u64::from(PERSIST_REPLY_TIMEOUT_MS));
    match client.request_waiting(Request::PersistParams, wait, 1)? {
        Reply::Ack => Ok(()),
        other => Err(unexpected("PersistParams", other)),
    }
}

/// The record of the failure that ended a previous run, if the robot keeps one.
pub fn panic_record<T: Transport>(
    client: &mut Client<T>,
) -> Result<Option<PanicReport>, StationError> {
    match client.request(Request::GetPanicRecord)? {
        Reply::PanicRecord(record) => Ok(record),
        other => Err(unexpected("GetPanicRecord", other)),
    }
}

/// Tells the robot to forget its panic record (once it has been shown).
pub fn clear_panic_record<T: Transport>(client: &mut Client<T>) -> Result<(), StationError> {
    client.command(Request::ClearPanicRecord)
}

/// What `station info` prints: one `label  value` line per fact, the robot's `info`, the
/// previous run's `failure` and the `link`.
pub fn describe_robot(info: &RobotInfo, failure: Option<&PanicReport>, link: &str) -> String {
    let git = if info.git_hash.is_empty() {
        "no git hash"
    } else {
        info.git_hash.as_str()
    };
    let failure = match failure {
        Some(record) => format!("{record} (the robot's record, now cleared)"),
        None => "none recorded".to_string(),
    };
    [
        ("robot", info.robot_name.to_string()),
        ("chip", info.chip.to_string()),
        ("firmware", format!("{} ({git})", info.firmware_version)),
        ("protocol", info.protocol.to_string()),
        ("parameters", format!("hash 0x{:08x}", info.params_hash)),
        ("bridge", info.bridge.to_string()),
        ("clock", info.clock.to_string()),
        ("brown-out", brown_out_text(info.brown_out_reset)),
        ("last reset", reset_text(info.reset_cause).to_string()),
        ("last failure", failure),
        ("link", link.to_string()),
    ]
    .iter()
    .map(|(label, value)| format!("{label:<13}{value}\n"))
    .collect()
}

/// Why the chip last reset, and what it says about the run before (one phrase, for
/// `station info` and bring-up).
pub fn reset_text(cause: ResetCause) -> &'static str {
    match cause {
        ResetCause::PowerOn => "power-on",
        ResetCause::Pin => "the reset pin (the board's button or a probe)",
        ResetCause::Software => "a software reset",
        ResetCause::Watchdog => {
            "the watchdog: the control loop stalled in the run before (see the last failure)"
        }
        ResetCause::BrownOut => {
            "brown-out: the supply sagged below the brown-out level while running (check the \
             battery and its connector)"
        }
        ResetCause::LowPower => "a low-power-management reset",
        ResetCause::Unknown => "unknown (no reset flag set)",
    }
}

/// The brown-out reset level with its thresholds, and what it means for persisting.
fn brown_out_text(level: BrownOutReset) -> String {
    let bor = match level {
        BrownOutReset::NotApplicable => return level.to_string(),
        BrownOutReset::Off => BorLevel::Off,
        BrownOutReset::Level1 => BorLevel::Level1,
        BrownOutReset::Level2 => BorLevel::Level2,
        BrownOutReset::Level3 => BorLevel::Level3,
    };
    let mv = |v: u16| f64::from(v) / 1000.0;
    let reset = match bor.falling_threshold_mv() {
        Some(t) => format!("resets below {:.2}–{:.2} V", mv(t.min), mv(t.max)),
        None => "only the power-on reset (about 1.7 V) stops the chip".to_string(),
    };
    if level.guards_flash_writes() {
        format!("{level}: {reset}")
    } else {
        format!("{level}: {reset}; parameters cannot be persisted")
    }
}

/// The start pose of `scenario` as the robot takes it (world frame, m and rad).
pub fn start_pose(scenario: &Scenario) -> Pose {
    let s = scenario.start;
    Pose::new(s.x_m as f32, s.y_m as f32, s.theta_rad as f32)
}

/// The body motion `scenario` starts in, if it starts moving (robot frame, m/s, rad/s).
pub fn initial_motion(scenario: &Scenario) -> Option<BodyVelocity> {
    let s = scenario.start;
    (s.v_m_s != 0.0 || s.omega_rad_s != 0.0)
        .then(|| BodyVelocity::new(s.v_m_s as f32, s.omega_rad_s as f32))
}

/// Uploads `scenario`'s path, reference speed and mode and start pose, to be followed
/// with `law`, under `upload_id`; commits it. `progress(sent, total)` after each chunk.
pub fn upload_path<T: Transport>(
    client: &mut Client<T>,
    scenario: &Scenario,
    law: LawKind,
    upload_id: u16,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<CommitSummary, StationError> {
    let plan = PathPlan {
        path: &scenario.path,
        speed_m_s: scenario.reference_speed_m_s,
        mode: scenario.reference_mode,
        law,
        start_pose: start_pose(scenario),
    };
    upload(client, &plan, upload_id, progress)
}

/// A path and how it is to be followed: what a path upload carries.
#[derive(Clone, Copy, Debug)]
pub struct PathPlan<'a> {
    /// The path, world frame.
    pub path: &'a Path,
    /// Reference speed along it, m/s.
    pub speed_m_s: f32,
    /// How the reference moves.
    pub mode: ReferenceMode,
    /// The steering law.
    pub law: LawKind,
    /// The path's start pose (world frame; m, m, rad): what the button's long press sets.
    pub start_pose: Pose,
}

/// Uploads `plan` under `upload_id` and commits it. `progress(sent, total)` after each
/// chunk.
pub fn upload<T: Transport>(
    client: &mut Client<T>,
    plan: &PathPlan<'_>,
    upload_id: u16,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<CommitSummary, StationError> {
    let segments = plan.path.segments();
    let count = u8::try_from(segments.len()).unwrap_or(u8::MAX);
    let begin = PathBegin {
        upload_id,
        segment_count: count,
        speed_m_s: plan.speed_m_s,
        mode: plan.mode,
        law: plan.law,
        start_pose: plan.start_pose,
    };
    client.request(Request::PathBegin(begin))?;
    let chunks: Vec<_> = upload::chunks(upload_id, segments).collect();
    let total = chunks.len();
    for (i, chunk) in chunks.into_iter().enumerate() {
        client.request(Request::PathChunk(chunk))?;
        progress(i + 1, total);
    }
    let commit = PathCommit {
        upload_id,
        segment_count: count,
        checksum: path_checksum(segments),
    };
    match client.request(Request::PathCommit(commit))? {
        Reply::PathCommitted(summary) => Ok(summary),
        other => Err(unexpected("PathCommit", other)),
    }
}

/// Arms the robot to follow its path, asserting `initial_motion` when it is already
/// moving, for at most `run_time_limit_steps` control steps (this run only; `None`: the
/// robot's stored limit).
pub fn arm<T: Transport>(
    client: &mut Client<T>,
    initial_motion: Option<BodyVelocity>,
    run_time_limit_steps: Option<u32>,
) -> Result<(), StationError> {
    client.command(Request::Arm {
        mode: ArmMode::FollowPath,
        initial_motion,
        run_time_limit_steps,
    })
}

/// Tells the disarmed robot it is at `pose` (world frame, the path's; m, m, rad): its
/// odometry is set there and its next path-following run starts the path afresh.
pub fn set_pose<T: Transport>(client: &mut Client<T>, pose: Pose) -> Result<(), StationError> {
    client.command(Request::SetPose {
        x_m: pose.x_m,
        y_m: pose.y_m,
        theta_rad: pose.theta_rad,
    })
}

/// An upload id that differs from the last few: the low bits of the clock.
pub fn fresh_upload_id() -> u16 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(1, |d| d.subsec_nanos());
    (nanos >> 10) as u16 | 1
}

/// The last tune's outcome as the robot holds it ([`Request::GetTuneReport`]).
pub fn tune_report<T: Transport>(client: &mut Client<T>) -> Result<TuneReport, StationError> {
    match client.request(Request::GetTuneReport)? {
        Reply::TuneReport(report) => Ok(report),
        other => Err(unexpected("GetTuneReport", other)),
    }
}

/// How a tune went ([`tune`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TuneRun {
    /// This tune's report; `None` when none came (the station gave up at its limit,
    /// disarmed, and the robot still held the previous tune's).
    pub report: Option<TuneReport>,
    /// The event that ended the tune, if it reached the station.
    pub ended_by: Option<Event>,
    /// The link failed once the robot was armed (the error's text); the robot disarms
    /// itself on its heartbeat timeout.
    pub link_error: Option<String>,
}

impl TuneRun {
    /// This tune's report if the tune finished (its outcome is a result), else why not:
    /// the robot's reason, with the event that ended the tune when it was not the tune's
    /// own end.
    pub fn finished(&self) -> Result<TuneReport, String> {
        let ended = match self.ended_by {
            Some(Event::Disarmed(DisarmReason::TuneFinished)) | None => String::new(),
            Some(event) => format!(" (ended by {event:?})"),
        };
        if let (Some(error), None) = (&self.link_error, self.report) {
            return Err(format!(
                "the link failed during the tune ({error}); the robot disarms itself on \
its heartbeat timeout"
            ));
        }
        match self.report {
            None => Err(format!(
                "the tune did not end within the station's limit; the robot was disarmed \
and sent no report{ended}"
            )),
            Some(report @ TuneReport { outcome: Ok(_), .. }) => Ok(report),
            Some(TuneReport {
                outcome: Err(why), ..
            }) => Err(format!("the tune stopped: {why}{ended}")),
        }
    }
}

/// Tunes the robot's wheel loops ([`ArmMode::Tune`]): arms it in tune mode, keeps it armed
/// with heartbeats paced by its own step counter (from 10 Hz telemetry; a robot whose
/// heartbeat timeout is `heartbeat_timeout_steps`) until the tune ends (the robot disarms
/// by itself, or a fault, the button or a link loss stops it), and returns this tune's
/// report, if one came. Gives up after `limit` of host time with the robot disarmed.
/// An error only when the robot was not armed; a link failure after that is
/// [`TuneRun::link_error`].
pub fn tune<T: Transport>(
    client: &mut Client<T>,
    heartbeat_timeout_steps: u32,
    limit: std::time::Duration,
) -> Result<TuneRun, StationError> {
    let before = tune_report(client)?.tunes_ended;
    crate::record::set_telemetry_rate(client, 10)?;
    client.command(Request::Arm {
        mode: ArmMode::Tune,
        initial_motion: None,
        run_time_limit_steps: None,
    })?;
    let mut run = TuneRun {
        report: None,
        ended_by: None,
        link_error: None,
    };
    if let Err(e) = hold_tune(client, heartbeat_timeout_steps, limit, before, &mut run) {
        run.link_error = Some(crate::error_text(&e));
    }
    Ok(run)
}

/// Keeps the tune armed until it ends or `limit`; fills `run`.
fn hold_tune<T: Transport>(
    client: &mut Client<T>,
    heartbeat_timeout_steps: u32,
    limit: std::time::Duration,
    before: u16,
    run: &mut TuneRun,
) -> Result<(), StationError> {
    let mut pacer = crate::record::HeartbeatPacer::new(heartbeat_timeout_steps);
    let mut robot_step = None;
    let start = std::time::Instant::now();
    let mut report = None;
    while report.is_none() && start.elapsed() < limit {
        if pacer.due(robot_step) {
            client.send_only(Request::Heartbeat)?;
        }
        match client.next_message(std::time::Duration::from_millis(10))? {
            Some(Uplink::Telemetry(frame)) => robot_step = Some(frame.step),
            Some(Uplink::TuneReport(r)) if r.tunes_ended != before => report = Some(r),
            Some(Uplink::Event {
                event: event @ (Event::Disarmed(_) | Event::Faulted),
                ..
            }) => {
                run.ended_by.get_or_insert(event);
                // The report follows the event; ask for it should it have been lost.
                let r = tune_report(client)?;
                if r.tunes_ended != before {
                    report = Some(r);
                }
            }
            _ => {}
        }
    }
    if report.is_none() {
        client.command(Request::Disarm)?;
        report = Some(tune_report(client)?).filter(|r| r.tunes_ended != before);
    }
    run.report = report;
    client.request(Request::SetTelemetryRate { hz: 1 })?;
    Ok(())
}

/// A tune's report as text: per wheel the identified model, the tune's warnings (a line
/// `# warning: …`, when it has any), then the wheel loops as a robot file's sections
/// (ready for `station params set`), or why the tune stopped.
pub fn describe_tune(report: &TuneReport) -> String {
    if report.tunes_ended == 0 {
        return "no tune has ended on this robot since it started".to_string();
    }
    match report.outcome {
        Err(why) => format!("the tune stopped: {why}"),
        Ok(result) => {
            let mut text = String::new();
            for (side, m) in ["left ", "right"].iter().zip(result.models) {
                text.push_str(&format!(
                    "# {side}: k_S {:.3} V, k_V {:.5} V/(rad/s), K {:.3} rad/s/V, τ {:.1} ms, \
θ {:.1} ms, design τ {:.1} ms\n",
                    m.ks_v,
                    m.kv_v_per_rad_s,
                    m.gain_rad_s_per_v,
                    m.time_constant_s * 1e3,
                    m.dead_time_s * 1e3,
                    m.design_time_constant_s * 1e3
                ));
            }
            if result.warnings.any() {
                text.push_str(&format!("# warning: {}\n", result.warnings));
            }
            text.push_str(&tuned_wheel_sections(&result));
            text
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use link::{
        bounded, encode, ClockSource, Decoder, Downlink, FailureKind, ProtocolId, Received,
    };

    fn info(clock: ClockSource, brown_out_reset: BrownOutReset) -> RobotInfo {
        RobotInfo {
            protocol: ProtocolId::OURS,
            firmware_version: bounded("0.1.0"),
            git_hash: bounded("0123456789ab"),
            chip: bounded("STM32F411"),
            robot_name: bounded("diff-drive"),
            params_hash: 0x1234_5678,
            bridge: link::BridgeChip::Drv8833,
            clock,
            brown_out_reset,
            reset_cause: ResetCause::Watchdog,
        }
    }

    fn line<'a>(text: &'a str, label: &str) -> &'a str {
        text.lines()
            .find_map(|l| l.strip_prefix(label))
            .unwrap_or_else(|| panic!("no {label} in\n{text}"))
            .trim()
    }

    #[test]
    fn info_shows_the_clock_the_brown_out_level_and_the_last_failure() {
        let crystal = info(
            ClockSource::Crystal { hz: 25_000_000 },
            BrownOutReset::Level3,
        );
        let text = describe_robot(&crystal, None, "/dev/ttyACM0 at 230400 baud");
        assert_eq!(line(&text, "clock"), "25 MHz crystal");
        assert_eq!(
            line(&text, "brown-out"),
            "level 3: resets below 2.75–2.88 V"
        );
        assert_eq!(line(&text, "last failure"), "none recorded");
        assert_eq!(line(&text, "parameters"), "hash 0x12345678");
        assert_eq!(
            line(&text, "bridge"),
            "DRV8833: 2S Li-ion (8.4 V full) at most"
        );
        assert!(
            line(&text, "last reset").starts_with("the watchdog"),
            "{text}"
        );

        let fallen_back = info(
            ClockSource::InternalFallback {
                expected_hz: 8_000_000,
            },
            BrownOutReset::Off,
        );
        let record = PanicReport {
            kind: FailureKind::Panic,
            file: bounded("src/board/f411/motor.rs"),
            line: 42,
            pc: 0,
            message: bounded("index out of bounds"),
        };
        let text = describe_robot(&fallen_back, Some(&record), "tcp");
        assert!(
            line(&text, "clock").starts_with("internal RC oscillator: the 8 MHz external"),
            "{text}"
        );
        assert_eq!(
            line(&text, "brown-out"),
            "off: only the power-on reset (about 1.7 V) stops the chip; parameters cannot be \
             persisted"
        );
        assert!(
            line(&text, "last failure")
                .starts_with("panic at src/board/f411/motor.rs:42: index out of bounds"),
            "{text}"
        );
    }

    /// A robot busy erasing its flash: it answers `PersistParams` only after the station
    /// has waited `answer_after` in `receive`, as a stalled robot would. Counts what the
    /// station sent.
    struct ErasingRobot {
        sends: Vec<u16>,
        waited: Duration,
        answer_after: Duration,
        reply: Vec<u8>,
    }

    impl Transport for ErasingRobot {
        fn send(&mut self, bytes: &[u8]) -> std::io::Result<()> {
            for outcome in Decoder::new().feed::<Downlink>(bytes) {
                if let Ok(Received::Message(Downlink { seq, request })) = outcome {
                    assert_eq!(request, Request::PersistParams);
                    self.sends.push(seq);
                    let mut frame = [0u8; link::MAX_FRAME_LEN];
                    let reply = Uplink::Reply {
                        seq,
                        result: Ok(Reply::Ack),
                    };
                    let len = encode(&reply, &mut frame).expect("encodable");
                    self.reply = frame[..len].to_vec();
                }
            }
            Ok(())
        }

        fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> std::io::Result<usize> {
            // The station's patience, not the wall clock: what it asks to wait for.
            self.waited += timeout;
            if self.waited < self.answer_after {
                // Block for the time asked, as a quiet line does.
                std::thread::sleep(timeout);
                return Ok(0);
            }
            let n = self.reply.len().min(buf.len());
            buf[..n].copy_from_slice(&self.reply[..n]);
            self.reply.drain(..n);
            Ok(n)
        }

        fn describe(&self) -> String {
            "erasing robot".to_string()
        }
    }

    #[test]
    fn a_persist_is_sent_once_and_waits_out_the_erase() {
        // The longest erase is 2 s: the robot answers after that.
        let robot = ErasingRobot {
            sends: Vec::new(),
            waited: Duration::ZERO,
            answer_after: Duration::from_secs(2),
            reply: Vec::new(),
        };
        let mut client = Client::new(robot);
        persist_params(&mut client).expect("the reply after the erase");
        let robot = client.transport();
        assert_eq!(robot.sends.len(), 1, "sent once: {:?}", robot.sends);
        assert!(
            robot.waited >= Duration::from_millis(2_500),
            "{:?}",
            robot.waited
        );
    }

    #[test]
    fn empty_sections_are_left_out() {
        let text = "[robot]\na = 1\n\n[robot.wheels]\n\n[robot.left_wheel]\n# a comment\n\
b = 2\n\n[robot.none]\n# only a comment\n\n[supervisor]\n";
        assert_eq!(
            without_empty_sections(text),
            "[robot]\na = 1\n\n[robot.left_wheel]\n# a comment\nb = 2\n\n"
        );
        assert_eq!(without_empty_sections("a = 1\n"), "a = 1\n");
    }

    #[test]
    fn a_tunes_warnings_are_shown_before_its_gains() {
        use controller_core::params::RobotConfig;
        use controller_core::tune::{TuneResult, TuneWarnings, WheelModel};
        let mut result = TuneResult {
            models: [WheelModel::default(); 2],
            loops: [RobotConfig::REFERENCE_ROBOT.left_wheel; 2],
            warnings: TuneWarnings::default(),
        };
        let report = |result| TuneReport {
            tunes_ended: 1,
            outcome: Ok(result),
        };
        assert!(!describe_tune(&report(result)).contains("warning"));
        result.warnings.step_not_settled[1] = true;
        let text = describe_tune(&report(result));
        let warning = "# warning: Right wheel's step had not settled (τ likely low)\n";
        assert!(text.contains(warning), "{text}");
        assert!(
            text.find(warning) < text.find("[robot.left_wheel]"),
            "{text}"
        );
    }
}
