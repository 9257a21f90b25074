//! Test support: the virtual robot (`host-sim`'s) in the test's own process, behind the
//! station's [`Transport`], in lockstep, with the line's faults the tests ask for
//! ([`LineFaults`]).

use std::io;
use std::time::Duration;

use host_sim::serve::VirtualRobot;
use link::{Decoder, Downlink, Received, Request, Uplink};
use station::transport::Transport;

/// What the line between the station and the robot does wrong (nothing by default).
/// Armings are counted from 1, in the order the robot arms (an `Arm` it refuses is no
/// arming); an arming's steps count from the step its `Arm` was sent.
#[derive(Clone, Debug, Default)]
pub struct LineFaults {
    /// (arming, steps): during these armings, heartbeats sent more than `steps` control
    /// steps after the `Arm` never reach the robot, which then disarms on its heartbeat
    /// timeout (`LinkLost`) as if the station had stalled.
    pub mute_heartbeats: Vec<(u32, u32)>,
    /// (arming, steps): the connection breaks `steps` control steps after that `Arm`:
    /// every later send and receive fails.
    pub break_after: Option<(u32, u32)>,
    /// Every this many telemetry frames, one never reaches the station (0: none lost).
    pub lose_telemetry_every: u32,
    /// Every frame towards the station has a bit flipped (its CRC fails).
    pub corrupt_uplink: bool,
}

/// The virtual robot in this process, in lockstep: every `receive` with nothing pending
/// runs it for one control period, so a run's outcome does not depend on the host's
/// speed.
pub struct InProcess<'r, 'a> {
    robot: &'r mut VirtualRobot<'a>,
    /// The faults of the line.
    pub faults: LineFaults,
    /// Bytes for the station that passed the line, oldest first.
    pending: Vec<u8>,
    /// The robot's bytes of a frame not yet ended.
    partial: Vec<u8>,
    armings: u32,
    armed_at_step: u32,
    /// The step the last `Arm` was sent at.
    arm_sent_at_step: u32,
    telemetry_frames: u32,
    broken: bool,
}

impl<'r, 'a> InProcess<'r, 'a> {
    /// A faultless pipe to `robot`.
    pub fn new(robot: &'r mut VirtualRobot<'a>) -> Self {
        Self {
            robot,
            faults: LineFaults::default(),
            pending: Vec::new(),
            partial: Vec::new(),
            armings: 0,
            armed_at_step: 0,
            arm_sent_at_step: 0,
            telemetry_frames: 0,
            broken: false,
        }
    }

    /// Control steps since the last `Arm` the station sent.
    fn since_arming(&self) -> u32 {
        self.robot
            .control()
            .steps()
            .wrapping_sub(self.armed_at_step)
    }

    fn check_broken(&mut self) -> io::Result<()> {
        if let Some((arming, steps)) = self.faults.break_after {
            if self.armings > arming || (self.armings == arming && self.since_arming() >= steps) {
                self.broken = true;
            }
        }
        if self.broken {
            return Err(io::Error::new(
                io::ErrorKind::ConnectionAborted,
                "the robot closed the connection",
            ));
        }
        Ok(())
    }

    /// Whether the frame `bytes` (one whole frame, delimiter included) reaches the
    /// station, and flipped if the line corrupts it.
    fn pass_uplink(&mut self, mut frame: Vec<u8>) -> Option<Vec<u8>> {
        let message = Decoder::new().feed::<Uplink>(&frame).find_map(|o| match o {
            Ok(Received::Message(m)) => Some(m),
            _ => None,
        });
        if let Some(Uplink::Event {
            event: controller_core::supervisor::Event::Armed(_),
            ..
        }) = message
        {
            self.armings += 1;
            self.armed_at_step = self.arm_sent_at_step;
        }
        let is_telemetry = matches!(message, Some(Uplink::Telemetry(_)));
        if is_telemetry {
            self.telemetry_frames += 1;
            let every = self.faults.lose_telemetry_every;
            if every > 0 && self.telemetry_frames.is_multiple_of(every) {
                return None;
            }
        }
        if self.faults.corrupt_uplink && frame.len() > 2 {
            frame[1] ^= 0x10;
            if frame[1] == 0 {
                frame[1] = 0x10;
            }
        }
        Some(frame)
    }
}

impl Transport for InProcess<'_, '_> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.check_broken()?;
        // The station sends one whole frame at a time.
        let request = Decoder::new()
            .feed::<Downlink>(bytes)
            .find_map(|o| match o {
                Ok(Received::Message(Downlink { request, .. })) => Some(request),
                _ => None,
            });
        match request {
            Some(Request::Arm { .. }) => self.arm_sent_at_step = self.robot.control().steps(),
            Some(Request::Heartbeat) => {
                let since = self.since_arming();
                let muted = self
                    .faults
                    .mute_heartbeats
                    .iter()
                    .any(|&(arming, steps)| arming == self.armings && since > steps);
                if muted {
                    return Ok(());
                }
            }
            _ => {}
        }
        self.robot.receive(bytes);
        Ok(())
    }

    fn receive(&mut self, buf: &mut [u8], _timeout: Duration) -> io::Result<usize> {
        self.check_broken()?;
        if self.pending.is_empty() {
            if self.robot.outgoing().is_empty() {
                self.robot.step();
            }
            let out = self.robot.outgoing().to_vec();
            self.robot.consume(out.len());
            for byte in out {
                self.partial.push(byte);
                if byte == 0 {
                    let frame = std::mem::take(&mut self.partial);
                    if let Some(frame) = self.pass_uplink(frame) {
                        self.pending.extend_from_slice(&frame);
                    }
                }
            }
        }
        let n = self.pending.len().min(buf.len());
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }

    fn describe(&self) -> String {
        "virtual robot (in process)".to_string()
    }
}
