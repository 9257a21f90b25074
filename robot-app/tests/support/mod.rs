//! A fake board for the host tests: two wheels with a first-order speed response that
//! turn duties into encoder ticks, and a byte pipe in place of the USART, which the test
//! drives in random-size chunks in both directions.

#![allow(dead_code)] // each test file uses part of it

use core::num::NonZeroU32;

use controller_core::controller::{MotorCommand, TickDeltas};
use controller_core::kinematics::{Point, Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::params::RobotConfig;
use controller_core::path::Path;
use controller_core::reference::{Reference, ReferenceMode};
use controller_core::supervisor::{Bridge, Event, ResetCause, SupervisorConfig};
use link::{
    encode, Decoder, Downlink, ParamSet, Received, Refusal, Reply, Request, TelemetryFrame, Uplink,
    MAX_FRAME_LEN,
};
use robot_app::outer::OuterLoopWorker;
use robot_app::stm32f4::bridge::BridgeChip;
use robot_app::{
    start, Actuation, AppConfig, Channels, ControlSide, Identity, LinkOptions, LinkService,
    NoBoardStats, Sensors,
};

/// Control rate of the test robot, Hz.
pub const RATE_HZ: u32 = 1000;
/// The test robot's supply, V.
pub const SUPPLY_V: f32 = 6.0;

/// Who the test robot is.
pub const IDENTITY: Identity = Identity {
    firmware_version: "0.1.0-test",
    git_hash: "0123456789ab-dirty",
    chip: "host",
    robot_name: "fake board",
    clock: link::ClockSource::Crystal { hz: 25_000_000 },
    brown_out_reset: link::BrownOutReset::Level3,
};

/// The configuration the test robot starts with: the reference robot at 1 kHz, starting
/// at the origin heading along +x.
pub fn default_params() -> ParamSet {
    ParamSet {
        robot: RobotConfig::REFERENCE_ROBOT,
        supervisor: SupervisorConfig::at_rate(RATE_HZ, Pose::default(), WheelSpeeds::new(5.0, 5.0)),
    }
}

/// The board's built-in path: 2 m along +x from the origin at 0.2 m/s.
pub fn default_reference() -> Reference {
    let line = Path::line(Point::new(0.0, 0.0), 0.0, 2.0).expect("a valid line");
    Reference::new(
        line,
        0.2,
        ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        },
    )
    .expect("a valid reference")
}

/// The configuration of a test robot on a link at `baud`.
pub fn app_config(baud: u32, storage: bool) -> AppConfig {
    AppConfig {
        params: default_params(),
        reference: default_reference(),
        law: LawKind::Tracking,
        reset: ResetCause::PowerOn,
        identity: IDENTITY,
        link: LinkOptions {
            baud,
            telemetry_hz: 0,
            storage,
        },
        bridge: BridgeChip::Tb6612fng,
    }
}

/// A small deterministic random source (xorshift64*).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }

    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// A value in `lo..=hi`.
    pub fn range(&mut self, lo: usize, hi: usize) -> usize {
        lo + (self.next() % (hi - lo + 1) as u64) as usize
    }
}

/// Two wheels whose speed follows the applied voltage with a 50 ms time constant (about
/// the reference robot's motors, no load), counted by 1440-line-per-turn encoders.
pub struct Wheels {
    speed_rad_s: [f32; 2],
    /// Fractional ticks not yet counted.
    carry: [f32; 2],
}

impl Wheels {
    const KS_V: f32 = 0.33;
    const KV_V_PER_RAD_S: f32 = 0.157;
    const TAU_S: f32 = 0.05;
    const TICKS_PER_RAD: f32 = 1440.0 / core::f32::consts::TAU;

    pub fn new() -> Self {
        Self {
            speed_rad_s: [0.0; 2],
            carry: [0.0; 2],
        }
    }

    /// Advances `periods` control periods with `duty` applied through `bridge`; the ticks
    /// counted.
    pub fn step(&mut self, duty: MotorCommand, bridge: Bridge, periods: u32) -> TickDeltas {
        let dt = periods as f32 / RATE_HZ as f32;
        let mut ticks = [0i32; 2];
        for (i, d) in [duty.left, duty.right].into_iter().enumerate() {
            let volts = if bridge == Bridge::Drive {
                d * SUPPLY_V
            } else {
                0.0
            };
            let drive = (volts.abs() - Self::KS_V).max(0.0) * volts.signum();
            let target = drive / Self::KV_V_PER_RAD_S;
            let w = &mut self.speed_rad_s[i];
            *w += (target - *w) * (dt / Self::TAU_S).min(1.0);
            let exact = *w * dt * Self::TICKS_PER_RAD + self.carry[i];
            let whole = exact.trunc();
            self.carry[i] = exact - whole;
            ticks[i] = whole as i32;
        }
        TickDeltas {
            left: ticks[0],
            right: ticks[1],
        }
    }
}

/// The robot on a fake board, and the host at the other end of its byte pipe.
pub struct Rig<'a> {
    pub control: ControlSide<'a>,
    pub link: LinkService<'a>,
    pub wheels: Wheels,
    pub rng: Rng,
    /// Bytes on their way to the robot.
    pub to_robot: Vec<u8>,
    /// Everything the host decoded from the robot, in order.
    pub received: Vec<Uplink>,
    /// The host's decoder.
    pub host: Decoder,
    /// The line from the robot is stalled (its bytes stay in the robot's buffer).
    pub tx_paused: bool,
    /// The button is held.
    pub button: bool,
    /// Periods the next step covers (missed ticks when > 1).
    pub periods: u32,
    /// Send a `Heartbeat` every this many steps.
    pub heartbeat_every: Option<u32>,
    /// The last actuation.
    pub last: Option<Actuation>,
    /// The outer loop's worker when the control side lends it (as the firmware does).
    pub worker: Option<OuterLoopWorker<'a>>,
    /// Leave the outer loop unrun for this many steps after the next step that lends it
    /// (it overruns the period; 0: it runs between every two steps).
    pub stall_worker_steps: u32,
    /// The stall has begun.
    stalling: bool,
    next_seq: u16,
    background: u32,
}

impl<'a> Rig<'a> {
    /// A test robot on a link at `baud`, with or without storage.
    pub fn new(channels: &'a mut Channels, baud: u32, storage: bool) -> Self {
        Self::with_config(channels, app_config(baud, storage))
    }

    /// A test robot started with `config`.
    pub fn with_config(channels: &'a mut Channels, config: AppConfig) -> Self {
        let (control, link) = start(channels, config).expect("valid config");
        Self {
            control,
            link,
            wheels: Wheels::new(),
            rng: Rng::new(0x5eed),
            to_robot: Vec::new(),
            received: Vec::new(),
            host: Decoder::new(),
            tx_paused: false,
            button: false,
            periods: 1,
            heartbeat_every: None,
            last: None,
            worker: None,
            stall_worker_steps: 0,
            stalling: false,
            next_seq: 1000,
            background: 0,
        }
    }

    /// Frames `request` under `seq` and puts it on the line.
    pub fn send_with_seq(&mut self, seq: u16, request: Request) {
        let mut frame = [0u8; MAX_FRAME_LEN];
        let len = encode(&Downlink { seq, request }, &mut frame).expect("encodable");
        self.to_robot.extend_from_slice(&frame[..len]);
    }

    /// The same robot lending its outer loop to a worker run between steps.
    pub fn lending(channels: &'a mut Channels, baud: u32, storage: bool) -> Self {
        let mut rig = Self::new(channels, baud, storage);
        rig.worker = rig.control.lend_outer_loop();
        assert!(rig.worker.is_some());
        assert!(rig.control.lend_outer_loop().is_none(), "lent once");
        rig
    }

    /// The reference the controller follows (its outer loop is held between steps).
    pub fn active_reference(&self) -> &Reference {
        self.control
            .controller()
            .steering()
            .expect("the outer loop is held between steps")
            .reference()
    }

    /// The steering law the controller follows it with.
    pub fn active_law(&self) -> LawKind {
        self.control
            .controller()
            .steering()
            .expect("the outer loop is held between steps")
            .law()
    }

    /// Sends `request` under a fresh `seq`; returns the seq.
    pub fn send(&mut self, request: Request) -> u16 {
        let seq = self.fresh_seq();
        self.send_with_seq(seq, request);
        seq
    }

    /// A sequence number not used yet.
    pub fn fresh_seq(&mut self) -> u16 {
        self.next_seq = self.next_seq.wrapping_add(1);
        self.next_seq
    }

    /// One control period: bytes in (random chunks), the control step, the link's poll,
    /// bytes out (random chunks).
    pub fn step(&mut self) -> Actuation {
        if let Some(every) = self.heartbeat_every {
            if self.control.steps() % every == 0 {
                self.send(Request::Heartbeat);
            }
        }
        // The robot takes what it is ready for, in random-size chunks.
        let mut offered = 0;
        while offered < self.to_robot.len() {
            let chunk = self.rng.range(1, 40).min(self.to_robot.len() - offered);
            let taken = self
                .link
                .receive(&self.to_robot[offered..offered + chunk], &NoBoardStats);
            offered += taken;
            if taken < chunk {
                break;
            }
        }
        self.to_robot.drain(..offered);

        let last = self.last;
        let (duty, bridge) =
            last.map_or((MotorCommand::STOP, Bridge::Coast), |a| (a.duty, a.bridge));
        let periods = self.periods;
        self.background = self.background.wrapping_add(1);
        let out = self.control.step(Sensors {
            ticks: self.wheels.step(duty, bridge, periods),
            periods: NonZeroU32::new(periods).unwrap_or(NonZeroU32::MIN),
            supply_v: SUPPLY_V,
            button_pressed: self.button,
            overrun: false,
            background_heartbeat: self.background,
            gyro: None,
        });
        self.last = Some(out);
        // The lower-priority task runs between this step and the next.
        if let Some(worker) = &mut self.worker {
            self.stalling |= self.stall_worker_steps > 0 && out.steering_lent;
            if self.stalling {
                self.stall_worker_steps -= 1;
                self.stalling = self.stall_worker_steps > 0;
            } else {
                worker.run();
            }
        }
        self.link.poll();
        if !self.tx_paused {
            self.drain_tx();
        }
        out
    }

    /// Everything sent so far straight into the link side at once, with no control step
    /// in between (as a link task that runs before the next control period would take
    /// it), then the link's poll and what it queued sent to the host.
    pub fn deliver_at_once(&mut self) {
        let bytes = std::mem::take(&mut self.to_robot);
        let taken = self.link.receive(&bytes, &NoBoardStats);
        assert_eq!(taken, bytes.len(), "the link side takes every byte");
        self.link.poll();
        self.drain_tx();
    }

    /// Sends what the robot has queued, in random-size chunks, to the host's decoder.
    pub fn drain_tx(&mut self) {
        loop {
            let pending = self.link.outgoing();
            if pending.is_empty() {
                break;
            }
            let n = self.rng.range(1, 64).min(pending.len());
            let chunk = pending[..n].to_vec();
            self.link.consume(n);
            for outcome in self.host.feed::<Uplink>(&chunk) {
                match outcome {
                    Ok(Received::Message(m)) => self.received.push(m),
                    other => panic!("the host could not read the robot: {other:?}"),
                }
            }
            // Sending freed room: the robot may take more bytes and queue more.
            self.link.poll();
        }
    }

    /// `steps` control periods.
    pub fn run(&mut self, steps: u32) {
        for _ in 0..steps {
            self.step();
        }
    }

    /// The reply to `seq`, if it has arrived.
    pub fn reply(&self, seq: u16) -> Option<Result<Reply, Refusal>> {
        self.received.iter().find_map(|m| match m {
            Uplink::Reply { seq: s, result } if *s == seq => Some(result.clone()),
            _ => None,
        })
    }

    /// How many replies to `seq` arrived.
    pub fn replies_to(&self, seq: u16) -> usize {
        self.received
            .iter()
            .filter(|m| matches!(m, Uplink::Reply { seq: s, .. } if *s == seq))
            .count()
    }

    /// Sends `request` and steps until its reply arrives (at most 200 steps).
    pub fn ask(&mut self, request: Request) -> Result<Reply, Refusal> {
        let seq = self.send(request);
        for _ in 0..200 {
            self.step();
            if let Some(reply) = self.reply(seq) {
                return reply;
            }
        }
        panic!("no reply to seq {seq}");
    }

    /// The events received, in order.
    pub fn events(&self) -> Vec<Event> {
        self.received
            .iter()
            .filter_map(|m| match m {
                Uplink::Event { event, .. } => Some(*event),
                _ => None,
            })
            .collect()
    }

    /// The telemetry received, in order.
    pub fn telemetry(&self) -> Vec<TelemetryFrame> {
        self.received
            .iter()
            .filter_map(|m| match m {
                Uplink::Telemetry(t) => Some(*t),
                _ => None,
            })
            .collect()
    }
}
