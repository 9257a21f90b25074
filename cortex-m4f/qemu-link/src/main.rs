//! The link crate on an emulated Cortex-M4F.
//!
//! Run by `cargo xtask link-qemu` (and `cargo xtask ci`) as
//! `qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 -nographic -monitor none
//! -semihosting-config enable=on,target=native -chardev socket,… -serial chardev:… -kernel …`,
//! with USART1 connected to xtask through a TCP socket. The program:
//!
//! 1. enables USART1 (receive interrupt on) and sends one 0x00 byte: "ready" (bytes sent
//!    to QEMU's USART before it is enabled are lost, so the host waits for it);
//! 2. feeds every received byte to a [`link::Decoder`], answers each [`link::Downlink`]
//!    with an [`link::Uplink::Reply`] through [`link::encode`], and each frame of another
//!    protocol with [`link::Uplink::VersionMismatch`]; corrupted frames are only counted;
//! 3. after answering [`link::Request::GetStats`] (the host's last request), prints its
//!    counters through semihosting and exits with status 0 (1 on a panic or hard fault).

#![no_std]
#![no_main]

mod robot;
mod serial;

use core::panic::PanicInfo;

use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hprintln};
use link::{encode, Decoder, Downlink, Received, Request, Uplink, MAX_FRAME_LEN};
use stm32f4::stm32f405;

use crate::robot::TestRobot;
use crate::serial::Serial;

/// Everything the loop keeps, in one static place (reported as .bss by the size step).
struct Link {
    decoder: Decoder,
    robot: TestRobot,
    tx: [u8; MAX_FRAME_LEN],
    frames_sent: u32,
}

#[entry]
fn main() -> ! {
    let dp = stm32f405::Peripherals::take().unwrap_or_else(|| fail("peripherals taken"));
    let link: &'static mut Link = cortex_m::singleton!(: Link = Link {
        decoder: Decoder::new(),
        robot: TestRobot::new(),
        tx: [0; MAX_FRAME_LEN],
        frames_sent: 0,
    })
    .unwrap_or_else(|| fail("link state taken"));
    let mut serial = Serial::new(dp.USART1, &dp.RCC);
    serial.write(&[0]); // ready

    loop {
        let Some(byte) = serial.read() else {
            serial.wait();
            continue;
        };
        let Some(outcome) = link.decoder.push::<Downlink>(byte) else {
            continue;
        };
        let (reply, last) = match outcome {
            Ok(Received::Message(Downlink { seq, request })) => {
                let result = link.robot.answer(
                    &request,
                    link.decoder.counters(),
                    // This reply included.
                    link.frames_sent.wrapping_add(1),
                );
                (
                    Uplink::Reply { seq, result },
                    matches!(request, Request::GetStats),
                )
            }
            Ok(Received::Mismatch(received)) => (Uplink::VersionMismatch { received }, false),
            // Dropped and counted by the decoder: never answered.
            Err(_) => continue,
        };
        match encode(&reply, &mut link.tx) {
            Ok(len) => {
                serial.write(link.tx.get(..len).unwrap_or_default());
                link.frames_sent = link.frames_sent.wrapping_add(1);
            }
            Err(e) => fail_with(format_args!("encoding a reply: {e}")),
        }
        if last {
            report(&link.decoder, link.frames_sent, serial.lost());
            debug::exit(debug::EXIT_SUCCESS);
            halt();
        }
    }
}

fn report(decoder: &Decoder, frames_sent: u32, lost: u32) {
    let c = decoder.counters();
    hprintln!(
        "link on Cortex-M4F (guest): frames_ok={} crc_errors={} format_errors={} overflows={} \
         mismatches={} decode_errors={} frames_sent={} rx_bytes_lost={}",
        c.frames_ok,
        c.crc_errors,
        c.format_errors,
        c.overflows,
        c.mismatches,
        c.decode_errors,
        frames_sent,
        lost
    );
    hprintln!(
        "link state on Cortex-M4F: Decoder {} B, PathAssembler {} B, frame buffer {} B",
        core::mem::size_of::<Decoder>(),
        core::mem::size_of::<link::PathAssembler>(),
        MAX_FRAME_LEN
    );
}

fn fail(message: &str) -> ! {
    fail_with(format_args!("{message}"))
}

/// Prints `error: …` to the host's stderr and makes QEMU exit with status 1.
fn fail_with(args: core::fmt::Arguments<'_>) -> ! {
    use core::fmt::Write;
    if let Ok(mut stderr) = cortex_m_semihosting::hio::hstderr() {
        // Nothing more can be done if the host does not listen.
        let _ = writeln!(stderr, "error: {args}");
    }
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    fail_with(format_args!("panic: {info}"))
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    fail_with(format_args!("hard fault: {frame:?}"))
}
