//! # robot-app
//!
//! The robot's application logic with no board in it. The firmware (`firmware`, on the
//! STM32F411 and on the emulated `netduinoplus2` board) and the simulator's virtual robot
//! (`host-sim serve`) run exactly this code; what differs between them is only where the
//! numbers come from (timers, ADC, USART) and where they go (PWM, pins).
//!
//! | module | what it is | runs in |
//! |---|---|---|
//! | [`control`] | [`ControlSide`]: supervisor, controller, run metrics; one step per control period | the control interrupt |
//! | [`service`] | [`LinkService`]: decodes requests, answers, stages, forwards; encodes replies, events, telemetry | the link task |
//! | [`channel`] | [`Channels`]: lock-free queues, the staging mailbox and status atomics between the two | both (one end each) |
//! | [`persist`] | the parameter record in flash and the two-page rotation, as pure functions | the link task (and `init`) |
//! | [`metrics`] | run metrics (settle time, final and windowed errors) in fixed memory | the control interrupt |
//! | [`stm32f4`] | the STM32F4's register arithmetic (clocks, timers, watchdog, ADC, USART, flash, reset flags), with host tests | `init` |
//! | [`first_flash`] | the first-flash programs' arithmetic: the motor test pulse's bounds, the encoder's answer, wheel speed, the supply scale against a multimeter | the firmware's `examples/` |
//! | [`panic_record`] | the record of the last panic or hard fault kept in RAM across a reset | panic handler, `init` |
//!
//! # How a board wires it
//!
//! | call | context (RTIC 2 firmware) | when |
//! |---|---|---|
//! | [`start`]`(&mut channels, config)` | `init` | once; gives both sides |
//! | [`ControlSide::step`]`(sensors) -> Actuation` | control interrupt (TIM5, highest priority) | every tick |
//! | [`LinkService::ready_for_input`], [`LinkService::receive_byte`] | link task (lowest priority but idle) | while bytes wait in the receive ring |
//! | [`LinkService::poll`] | link task | when a step says [`Actuation::link_has_work`], and after sending |
//! | [`LinkService::outgoing`], [`LinkService::consume`] | link task | start a transmission; after it completed |
//! | [`LinkService::persist_job`], [`LinkService::persist_finished`] | link task | after `poll`; around the flash work |
//!
//! - **Control interrupt**: owns the [`ControlSide`] (a `#[local]` resource). It reads
//!   the encoders, button, supply and the `overrun` flag into [`Sensors`], calls
//!   [`ControlSide::step`], writes the duties and the bridge, feeds the watchdog when
//!   [`Actuation::feed_watchdog`], sets the LED, and pends the link task when
//!   [`Actuation::link_has_work`] (e.g. `link::spawn()`, ignoring "already pending").
//!   The step never waits, allocates, logs or panics. Its work is bounded: at most one
//!   request from the link, one reply, one event, one telemetry sample per step.
//!   Installing a staged configuration or path (only while disarmed) rebuilds the
//!   controller in place, field by field, copying the path straight from the staging
//!   area. `docs/realtime.md` draws the whole step and the tasks around it.
//! - **Steering task** (below the control interrupt): runs the outer loop's job when a
//!   step says [`Actuation::steering_lent`] (`crate::outer`).
//! - **USART RX interrupt**: pushes each received byte into a byte ring the board owns
//!   ([`channel::ring::Ring`]`<u8, N>`, split: producer in the interrupt, consumer in
//!   the link task; lock-free) and pends the link task. A full ring drops the byte: the
//!   frame fails its CRC, is counted, and the host re-sends.
//! - **Link task**: owns the [`LinkService`] (a `#[local]` resource). It moves bytes from
//!   the receive ring into [`LinkService::receive_byte`] while
//!   [`LinkService::ready_for_input`] (otherwise they wait: the transmit buffer must keep
//!   room for the replies), calls [`LinkService::poll`], starts sending
//!   [`LinkService::outgoing`] (DMA or TXE interrupt; the bytes stay in place until
//!   [`LinkService::consume`]), and, when [`LinkService::persist_job`] is `Some`,
//!   lengthens the watchdog, writes flash with [`persist::Slots`] and [`persist::encode`],
//!   reads it back with [`persist::decode`], restores the watchdog and calls
//!   [`LinkService::persist_finished`]. A transmit-complete interrupt only pends the link
//!   task, which calls `consume`.
//! - **Board statistics** for `GetStats` come through [`BoardStats`]: the control
//!   interrupt keeps its longest step in an `AtomicU32`, the link task reads it. The
//!   panic record for `GetPanicRecord` comes through [`PanicRecordStore`] (RAM that
//!   survives a reset); [`Board`] is both.
//!
//! **Locks: none between the control interrupt and the link task.** Every queue has one
//! producer and one consumer ([`Channels::split`] hands out the ends; move each into its
//! task's locals), the staging area hands its item over with an atomic state, and the
//! counters and telemetry rate are atomics. So the control interrupt never waits for the
//! link task, and no RTIC `lock` is needed. Put the [`Channels`] in a `static`
//! (`#[init(local = [channels: Channels = Channels::new()])]`) so both ends are
//! `'static`. If the board shares the [`LinkService`] between the link task and a UART
//! interrupt instead, that lock is between those two only, for one call each.
//!
//! The simulator runs the same calls in one thread: bytes from its socket into
//! `receive`, `step`, `poll`, `outgoing` to the socket, `consume`.
//!
//! ```
//! use controller_core::prelude::*;
//! use controller_core::supervisor::{ResetCause, SupervisorConfig};
//! use link::{encode, Decoder, Downlink, ParamSet, Received, Reply, Request, Uplink};
//! use robot_app::stm32f4::bridge::BridgeChip;
//! use robot_app::{start, AppConfig, Channels, Identity, LinkOptions, NoBoardStats, Sensors};
//!
//! let line = Path::line(Point::new(0.0, 0.0), 0.0, 2.0).unwrap();
//! let config = AppConfig {
//!     params: ParamSet {
//!         robot: RobotConfig::REFERENCE_ROBOT,
//!         supervisor: SupervisorConfig::at_rate(1000, Pose::default(), WheelSpeeds::default()),
//!     },
//!     reference: Reference::new(line, 0.2, ReferenceMode::TimeIndexed { start_offset_m: 0.0 })
//!         .unwrap(),
//!     law: LawKind::Tracking,
//!     reset: ResetCause::PowerOn,
//!     identity: Identity {
//!         firmware_version: "0.1.0",
//!         git_hash: "",
//!         chip: "host",
//!         robot_name: "doc",
//!         clock: link::ClockSource::Simulated,
//!         brown_out_reset: link::BrownOutReset::Level3,
//!     },
//!     link: LinkOptions { baud: 115_200, telemetry_hz: 0, storage: false },
//!     bridge: BridgeChip::Tb6612fng,
//! };
//! let mut channels = Channels::new();
//! let (mut control, mut link) = start(&mut channels, config).unwrap();
//!
//! // The host pings; the robot's loop runs one control period.
//! let mut frame = [0u8; link::MAX_FRAME_LEN];
//! let len = encode(&Downlink { seq: 1, request: Request::Ping { nonce: 7 } }, &mut frame)?;
//! assert_eq!(link.receive(&frame[..len], &NoBoardStats), len);
//! let out = control.step(Sensors::at_rest(6.0));
//! link.poll();
//! assert_eq!(out.duty, MotorCommand::STOP); // disarmed
//!
//! let mut host = Decoder::new();
//! let replies: Vec<_> = host.feed::<Uplink>(link.outgoing()).collect();
//! assert_eq!(replies, [Ok(Received::Message(Uplink::Reply { seq: 1, result: Ok(Reply::Pong { nonce: 7 }) }))]);
//! let sent = link.outgoing().len();
//! link.consume(sent);
//! # Ok::<(), link::EncodeError>(())
//! ```
//!
//! # RAM
//!
//! Everything is static: no heap. The control side holds the controller (with two
//! wheel-speed windows) and the supervisor (with the wheel-loop tune's state); the link
//! service the frame decoder, the transmit buffer of [`service::TX_CAPACITY`] bytes, the
//! active configuration and the last run and tune reports; the channels the staging area
//! (a slot for one path, where uploads are also assembled) and the outer loop with its
//! reference and path. A path is held twice: active in the outer loop, and staged. The
//! budgets below are checked at compile time wherever the crate is built; `cargo run -p
//! robot-app --example wiring` prints the sizes, and `cargo xtask size` the firmware's
//! static RAM against its budget.

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
// Only `channel::ring` and `channel::mailbox` use `unsafe` (shared slots between two
// contexts); everything else is safe code.
#![deny(unsafe_code)]

pub mod channel;
pub mod control;
pub mod first_flash;
pub mod metrics;
pub mod outer;
pub mod panic_record;
pub mod persist;
pub mod service;
mod start;
pub mod stm32f4;

pub use crate::channel::{Channels, ControlEnd, LinkEnd};
pub use crate::control::{Actuation, ControlSide, Sensors};
pub use crate::panic_record::PanicRecordStore;
pub use crate::service::{Board, BoardStats, Identity, LinkOptions, LinkService, NoBoardStats};
pub use crate::start::{start, AppConfig, StartError};

/// RAM budgets, checked wherever the crate is compiled (the target's sizes are a little
/// below the host's, whose pointers are 8 bytes).
const _: () = {
    assert!(core::mem::size_of::<ControlSide<'static>>() <= 3_072);
    assert!(core::mem::size_of::<LinkService<'static>>() <= 1_856);
    assert!(core::mem::size_of::<Channels>() <= 2_944);
};
