//! The core on an emulated Cortex-M4F.
//!
//! Run by `cargo xtask ci` as
//! `qemu-system-arm -cpu cortex-m4 -machine netduinoplus2 -nographic -monitor none
//! -serial none -semihosting-config enable=on,target=native -icount shift=0 -kernel …`.
//! QEMU does not model the STM32's clocks or timers' encoder mode, so this exercises the
//! core, not the HAL. It prints, through semihosting:
//!
//! 1. the [`Digest`](m4f_scenario::Digest) line of [`Scenario::paper_circle`], which
//!    xtask compares with the same scenario run on the host (they must be bit-identical);
//! 2. `control step on Cortex-M4F: N instructions` — a [`Controller::step`] in which the
//!    steering law runs (steering_divider = 1): odometry, speed estimate, reference, law,
//!    limits, inverse kinematics and both PIDs;
//! 3. `wheel step on Cortex-M4F: N instructions` — a step in which the law does not run.
//!
//! and exits through semihosting with status 0, or 1 on any failure (panic, hard fault).

#![no_std]
#![no_main]

mod counter;
mod timing;

use core::panic::PanicInfo;

use controller_core::controller::{Controller, TickDeltas};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hprintln};
use m4f_scenario::{run_scenario_with, Scenario};

use crate::timing::Calibration;

/// Steps timed per measurement: enough that the per-step mean is exact to a fraction of an
/// instruction.
const TIMED_STEPS: usize = 10_000;

#[entry]
fn main() -> ! {
    let peripherals = cortex_m::Peripherals::take().unwrap_or_else(|| fail("peripherals taken"));
    counter::start(peripherals.SYST);

    // 1. The digest. The tick deltas of its first steps are kept to drive the timing
    //    runs with a realistic trajectory.
    let scenario = Scenario::paper_circle();
    let mut recorded = [[0i8; 2]; TIMED_STEPS];
    let digest = run_scenario_with(&scenario, |r| {
        if let Some(slot) = recorded.get_mut(r.index as usize) {
            *slot = [saturate_i8(r.ticks.left), saturate_i8(r.ticks.right)];
        }
    })
    .unwrap_or_else(|e| fail_with(format_args!("scenario setup: {e}")));
    hprintln!("{}", digest);
    let (pose, truth) = (digest.pose(), digest.true_pose());
    hprintln!(
        "final pose: odometry ({}, {}, {}), true ({}, {}, {})",
        pose.x_m,
        pose.y_m,
        pose.theta_rad,
        truth.x_m,
        truth.y_m,
        truth.theta_rad
    );

    // 2. Instruction counts.
    let calibration = Calibration::measure();
    let ppm = calibration.ticks_per_instruction_ppm();
    hprintln!(
        "SysTick ticks per instruction: {}.{:06}",
        ppm / 1_000_000,
        ppm % 1_000_000
    );

    // Every step a steering step: each runs the law on the job the previous step handed
    // over and applies its outcome, so step 0 (which has none) runs untimed.
    let mut every_step = controller(&scenario, 1);
    timing::controller_step(&mut every_step, TickDeltas::default());
    expect_steering(&every_step, &recorded, true);
    let full = timing::per_call_tenths(&calibration, &every_step, &recorded);
    // The law is due at step 0 only (then not for 2³² − 1 steps), and step 1 runs and
    // applies it: run both untimed, then every timed step is a wheel step.
    let mut wheel_only = controller(&scenario, u32::MAX);
    timing::controller_step(&mut wheel_only, TickDeltas::default());
    timing::controller_step(&mut wheel_only, TickDeltas::default());
    expect_steering(&wheel_only, &recorded, false);
    let wheel = timing::per_call_tenths(&calibration, &wheel_only, &recorded);
    report("control step", full);
    report("wheel step", wheel);

    debug::exit(debug::EXIT_SUCCESS);
    halt()
}

/// The scenario's controller with the steering law run every `steering_divider` steps.
fn controller(scenario: &Scenario, steering_divider: u32) -> Controller {
    let mut s = *scenario;
    s.config.steering_divider = steering_divider;
    s.controller()
        .unwrap_or_else(|e| fail_with(format_args!("timing setup: {e}")))
        .0
}

/// Checks, untimed, on a copy of `controller`, that the steps about to be timed are all
/// steering steps (`steering`) or all wheel-only steps, so the labels printed are true.
fn expect_steering(controller: &Controller, ticks: &[[i8; 2]], steering: bool) {
    let mut c = controller.clone();
    for (i, pair) in ticks.iter().enumerate() {
        timing::controller_step(
            &mut c,
            TickDeltas {
                left: i32::from(pair[0]),
                right: i32::from(pair[1]),
            },
        );
        let telemetry = c.telemetry();
        if telemetry.steering_updated != steering {
            fail_with(format_args!(
                "timed step {i}: steering_updated = {}, expected {steering}",
                telemetry.steering_updated
            ));
        }
        if telemetry.faults.any() {
            fail_with(format_args!("timed step {i}: fault {:?}", telemetry.faults));
        }
    }
}

fn report(what: &str, tenths: u64) {
    hprintln!("{} on Cortex-M4F: {} instructions", what, (tenths + 5) / 10);
    hprintln!(
        "  ({}.{} per step, mean over {} steps)",
        tenths / 10,
        tenths % 10,
        TIMED_STEPS
    );
}

fn saturate_i8(x: i32) -> i8 {
    x.clamp(i32::from(i8::MIN), i32::from(i8::MAX)) as i8
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
