//! What the firmware measures about itself: the longest run of the control task and of
//! the link task (in the board's work unit: CPU cycles on the F411, instructions on the
//! emulated board), and the stack's high-water mark; and the [`BoardStats`] the link
//! service reports in `GetStats`.

use core::ptr::addr_of;
use core::sync::atomic::{AtomicU32, Ordering};

use robot_app::hw::stack::high_water_bytes;
use robot_app::BoardStats;

use crate::board;

/// The runs of one task: how many, and the longest, in raw [`board::work_counter`]
/// differences. Written by its task only; read from anywhere.
pub struct TaskTiming {
    longest_raw: AtomicU32,
    runs: AtomicU32,
}

impl TaskTiming {
    const fn new() -> Self {
        Self {
            longest_raw: AtomicU32::new(0),
            runs: AtomicU32::new(0),
        }
    }

    /// Records one run that started at the [`board::work_counter`] reading `started`.
    /// Only the task this timing is for calls it (relaxed loads and stores, no
    /// read-modify-write instruction needed).
    #[inline(always)]
    pub fn record_since(&self, started: u32) {
        let raw = board::work_counter().wrapping_sub(started);
        if raw > self.longest_raw.load(Ordering::Relaxed) {
            self.longest_raw.store(raw, Ordering::Relaxed);
        }
        let runs = self.runs.load(Ordering::Relaxed);
        self.runs.store(runs.wrapping_add(1), Ordering::Relaxed);
    }

    /// The longest run, in [`board::WORK_UNIT`]s.
    pub fn max_units(&self) -> u32 {
        board::work_units(self.longest_raw.load(Ordering::Relaxed))
    }

    /// Runs recorded (reported by the emulated board's plant port).
    #[cfg_attr(not(feature = "qemu"), allow(dead_code))]
    pub fn runs(&self) -> u32 {
        self.runs.load(Ordering::Relaxed)
    }
}

/// The control task (TIM5), from its first instruction to its last, every step.
pub static CONTROL: TaskTiming = TaskTiming::new();
/// The control task in the steps that end armed (the steps that drive the motors; the
/// longest step overall installs a new configuration or path, which happens only while
/// disarmed).
pub static CONTROL_ARMED: TaskTiming = TaskTiming::new();
/// The link task, each run.
pub static LINK: TaskTiming = TaskTiming::new();

/// Bytes of stack ever used: the painted stack region (cortex-m-rt's `paint-stack`,
/// between the linker symbols `_stack_end` and `_stack_start`, which flip-link moves
/// below the statics) scanned from the bottom for the first word the stack reached
/// (`robot_app::hw::stack`). Reads up to the whole region (about 124 KiB): call it
/// from the link task, not the control task.
pub fn stack_high_water_bytes() -> u32 {
    extern "C" {
        static _stack_end: u32;
        static _stack_start: u32;
    }
    let bottom = addr_of!(_stack_end);
    let top = addr_of!(_stack_start);
    let words = (top as usize).saturating_sub(bottom as usize) / 4;
    high_water_bytes((0..words).map(|i| {
        // SAFETY: `bottom + i` for `i < words` lies inside the stack region the linker
        // reserved (RAM, word-aligned: cortex-m-rt asserts both symbols' alignment);
        // volatile, because the compiler cannot know the stack writes to it.
        unsafe { bottom.add(i).read_volatile() }
    }))
}

/// The board's figures for the link's `GetStats`.
pub struct FirmwareStats;

impl BoardStats for FirmwareStats {
    fn max_step_cycles(&self) -> u32 {
        CONTROL.max_units()
    }

    fn stack_high_water_bytes(&self) -> u32 {
        stack_high_water_bytes()
    }
}
