//! Instructions per call of a function, measured with [`counter`](crate::counter).
//!
//! Under `-icount shift=0` QEMU executes one instruction per virtual nanosecond, so SysTick
//! counts instructions. The method: calibrate SysTick ticks per instruction at run time against two asm loops of known length (the fixed overhead of
//! reading the counter cancels), then time N calls of the function under test and N calls
//! of an empty `#[inline(never)]` function through the very same loop, and divide the
//! difference.

use core::arch::asm;
use core::hint::black_box;

use controller_core::controller::{Controller, MotorCommand, StepInput, TickDeltas};

use crate::counter;

/// Instructions in one iteration of [`spin`].
const SPIN_LOOP_INSTRUCTIONS: u64 = 10;
/// Iterations of the short and the long calibration loop.
const CALIBRATION_ITERATIONS: (u32, u32) = (100_000, 2_000_000);

/// Runs a loop of exactly [`SPIN_LOOP_INSTRUCTIONS`] instructions `iterations` times
/// (`iterations` ≥ 1).
#[inline(never)]
fn spin(iterations: u32) {
    // SAFETY: touches only the register it is given and the flags.
    unsafe {
        asm!(
            "2:",
            "nop", "nop", "nop", "nop", "nop", "nop", "nop", "nop",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) iterations => _,
            options(nomem, nostack),
        );
    }
}

/// SysTick ticks per instruction, as a ratio `ticks / instructions`.
#[derive(Clone, Copy, Debug)]
pub struct Calibration {
    /// Ticks counted over `instructions` instructions.
    pub ticks: u64,
    /// Instructions behind `ticks`.
    pub instructions: u64,
}

impl Calibration {
    /// Times the short and the long [`spin`] loop; their difference is a known number of
    /// instructions.
    pub fn measure() -> Self {
        let (short, long) = CALIBRATION_ITERATIONS;
        let time = |n: u32| {
            let t0 = counter::now();
            spin(black_box(n));
            counter::now() - t0
        };
        let t_short = time(short);
        let t_long = time(long);
        Self {
            ticks: t_long.saturating_sub(t_short).max(1),
            instructions: SPIN_LOOP_INSTRUCTIONS * u64::from(long - short),
        }
    }

    /// Ticks per instruction × 10⁶ (168 000 on netduinoplus2: a 168 MHz SysTick clock and
    /// 1 ns per instruction).
    pub fn ticks_per_instruction_ppm(&self) -> u64 {
        self.ticks * 1_000_000 / self.instructions
    }

    /// `ticks` converted to instructions, × 10, rounded.
    pub fn tenths_of_instructions(&self, ticks: u64, calls: u64) -> u64 {
        let num = u128::from(ticks) * u128::from(self.instructions) * 10;
        let den = u128::from(self.ticks) * u128::from(calls.max(1));
        ((num + den / 2) / den) as u64
    }
}

/// A function timed by [`per_call_tenths`].
pub type StepFn = fn(&mut Controller, TickDeltas) -> MotorCommand;

/// The baseline: does nothing, but is called exactly like the function under test.
#[inline(never)]
pub fn empty_step(_controller: &mut Controller, _ticks: TickDeltas) -> MotorCommand {
    MotorCommand::STOP
}

/// The supply voltage of the timed steps, V (as in the scenario).
pub const SUPPLY_V: f32 = 6.0;

/// One control step, as the firmware calls it.
#[inline(never)]
pub fn controller_step(controller: &mut Controller, ticks: TickDeltas) -> MotorCommand {
    controller.step(StepInput::on_time(ticks, SUPPLY_V))
}

/// Calls `step` once per entry of `ticks` and returns the SysTick ticks it took.
#[inline(never)]
fn timed_loop(controller: &mut Controller, ticks: &[[i8; 2]], step: StepFn) -> u64 {
    let step = black_box(step);
    let t0 = counter::now();
    for pair in ticks {
        let deltas = TickDeltas {
            left: i32::from(pair[0]),
            right: i32::from(pair[1]),
        };
        black_box(step(black_box(&mut *controller), black_box(deltas)));
    }
    counter::now() - t0
}

/// Instructions per call of `step` (× 10), driven by the recorded `ticks`, with the
/// loop's and the call's own cost removed by the same loop around [`empty_step`].
///
/// `controller` is cloned for the run so that the caller's stays as it was.
pub fn per_call_tenths(
    calibration: &Calibration,
    controller: &Controller,
    ticks: &[[i8; 2]],
) -> u64 {
    let mut under_test = controller.clone();
    let t_step = timed_loop(&mut under_test, ticks, controller_step);
    let mut baseline = controller.clone();
    let t_base = timed_loop(&mut baseline, ticks, empty_step);
    calibration.tenths_of_instructions(t_step.saturating_sub(t_base), ticks.len() as u64)
}
