//! The two sides wired together in one thread, as the simulator's virtual robot runs
//! them, with a host asking one question; then the RAM each part needs.
//!
//! `cargo run -p robot-app --example wiring`
//!
//! The sizes printed are this host's; on `thumbv7em-none-eabihf` (4-byte pointers) they
//! are a little smaller, and the crate checks its budget there at compile time (see the
//! crate doc, "RAM").

use core::mem::size_of;

use controller_core::kinematics::{Point, Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::params::RobotConfig;
use controller_core::path::Path;
use controller_core::reference::{Reference, ReferenceMode};
use controller_core::supervisor::{ResetCause, SupervisorConfig};
use link::{encode, Decoder, Downlink, ParamSet, Received, Request, Uplink, MAX_FRAME_LEN};
use robot_app::stm32f4::bridge::BridgeChip;
use robot_app::{
    start, AppConfig, Channels, ControlSide, Identity, LinkOptions, LinkService, NoBoardStats,
    Sensors,
};

fn main() {
    let line = Path::line(Point::new(0.0, 0.0), 0.0, 2.0).expect("a line");
    let reference = Reference::new(
        line,
        0.2,
        ReferenceMode::TimeIndexed {
            start_offset_m: 0.0,
        },
    )
    .expect("a reference");
    let config = AppConfig {
        params: ParamSet {
            robot: RobotConfig::REFERENCE_ROBOT,
            supervisor: SupervisorConfig::at_rate(1000, Pose::default(), WheelSpeeds::default()),
        },
        reference,
        law: LawKind::Tracking,
        reset: ResetCause::PowerOn,
        identity: Identity {
            firmware_version: env!("CARGO_PKG_VERSION"),
            git_hash: "unknown",
            chip: "host",
            robot_name: "example",
            clock: link::ClockSource::Simulated,
            brown_out_reset: link::BrownOutReset::NotApplicable,
        },
        link: LinkOptions {
            baud: 115_200,
            telemetry_hz: 0,
            storage: false,
        },
        bridge: BridgeChip::Tb6612fng,
    };
    let mut channels = Channels::new();
    let (mut control, mut link) = start(&mut channels, config).expect("a valid configuration");

    // The host asks who the robot is.
    let mut frame = [0u8; MAX_FRAME_LEN];
    let len = encode(
        &Downlink {
            seq: 1,
            request: Request::Info,
        },
        &mut frame,
    )
    .expect("a frame");
    let mut host = Decoder::new();
    let mut incoming = &frame[..len];
    for _ in 0..3 {
        // The USART's bytes, the control tick, the link task: one control period.
        let taken = link.receive(incoming, &NoBoardStats);
        incoming = &incoming[taken..];
        let out = control.step(Sensors::at_rest(6.0));
        if out.link_has_work {
            link.poll();
        }
        let sent = link.outgoing().len();
        for reply in host.feed::<Uplink>(link.outgoing()) {
            if let Ok(Received::Message(Uplink::Reply { seq, result })) = reply {
                println!("reply to {seq}: {result:?}");
            }
        }
        link.consume(sent);
    }

    println!("RAM on this host, bytes:");
    println!("  Channels     {:5}", size_of::<Channels>());
    println!("  ControlSide  {:5}", size_of::<ControlSide<'static>>());
    println!("  LinkService  {:5}", size_of::<LinkService<'static>>());
}
