//! What the firmware measures about itself: each task's runs, longest run and total, in
//! the board's work unit (CPU cycles on the F411, instructions on the emulated board),
//! and the stack's high-water mark, which the link service reports in `GetStats`
//! (`crate::link_task`).
//!
//! A task's run is its **own** time: from its first instruction to its last, less what
//! the higher-priority tasks that preempted it spent meanwhile. Every task charges its
//! own time to one running total ([`own_time_since`]), and a task's preemption is how
//! far that total moved during its run; so each instruction counts once, in the task
//! that ran it, however the tasks nest.

use core::ptr::addr_of;
use core::sync::atomic::{AtomicU32, Ordering};

use robot_app::stm32f4::stack::{high_water_bytes, PAINT};

use crate::board;

/// Every task's own time so far, raw [`board::work_since`] units, wrapping (see the
/// module doc).
static CHARGED_RAW: AtomicU32 = AtomicU32::new(0);

/// Where a task's run began: the work counter and the charged total then.
#[derive(Clone, Copy)]
pub struct Start {
    counter: u32,
    charged: u32,
}

/// The start of a task's run (its first statement).
#[inline(always)]
pub fn start() -> Start {
    Start {
        counter: board::work_counter(),
        charged: CHARGED_RAW.load(Ordering::Relaxed),
    }
}

/// The task's own time since `start`, raw units: the counter's advance less what the
/// tasks that preempted it charged meanwhile. Charges it in turn, so that the tasks this
/// one preempted do not count it as theirs. Call it once per run, last.
#[inline(always)]
pub fn own_time_since(start: Start) -> u32 {
    let elapsed = board::work_since(start.counter);
    let preempted = CHARGED_RAW
        .load(Ordering::Relaxed)
        .wrapping_sub(start.charged);
    let own = elapsed.saturating_sub(preempted);
    CHARGED_RAW.fetch_add(own, Ordering::Relaxed);
    own
}

/// The runs of one task: how many, the longest and their total, in raw
/// [`board::work_since`] units of its own time ([`own_time_since`]). Written by its task
/// only; read from anywhere.
pub struct TaskTiming {
    longest_raw: AtomicU32,
    runs: AtomicU32,
    /// All runs together, raw units, saturating.
    total_raw: AtomicU32,
}

impl TaskTiming {
    const fn new() -> Self {
        Self {
            longest_raw: AtomicU32::new(0),
            runs: AtomicU32::new(0),
            total_raw: AtomicU32::new(0),
        }
    }

    /// Records one run of `raw` own time ([`own_time_since`]). Only the task this timing
    /// is for calls it (relaxed loads and stores, no read-modify-write instruction
    /// needed).
    #[inline(always)]
    pub fn record(&self, raw: u32) {
        if raw > self.longest_raw.load(Ordering::Relaxed) {
            self.longest_raw.store(raw, Ordering::Relaxed);
        }
        let runs = self.runs.load(Ordering::Relaxed);
        self.runs.store(runs.wrapping_add(1), Ordering::Relaxed);
        let total = self.total_raw.load(Ordering::Relaxed);
        self.total_raw
            .store(total.saturating_add(raw), Ordering::Relaxed);
    }

    /// The longest run, in [`board::WORK_UNIT`]s.
    pub fn max_units(&self) -> u32 {
        board::work_units(self.longest_raw.load(Ordering::Relaxed))
    }

    /// Runs recorded, the longest and the total (reported by the emulated board's
    /// plant port, whose work unit is the instruction).
    #[cfg(feature = "qemu")]
    pub fn figures(&self) -> lockstep::TaskFigures {
        lockstep::TaskFigures {
            runs: self.runs.load(Ordering::Relaxed),
            max_instructions: self.max_units(),
            total_instructions: board::work_units(self.total_raw.load(Ordering::Relaxed)),
        }
    }
}

/// The control task (TIM5), every step: its own time (module doc).
pub static CONTROL: TaskTiming = TaskTiming::new();
/// The control task in the armed steady state: the steps that end armed and report no
/// event (the ones that drive the motors, arming and faults aside).
pub static CONTROL_ARMED: TaskTiming = TaskTiming::new();
/// The control task in the steps that arm (in motion or not).
pub static CONTROL_ARMING: TaskTiming = TaskTiming::new();
/// The link task, each run.
pub static LINK: TaskTiming = TaskTiming::new();
/// The link USART's interrupt, each run.
pub static LINK_UART: TaskTiming = TaskTiming::new();
/// The steering task: the outer loop the control task lends it.
pub static STEERING: TaskTiming = TaskTiming::new();

/// The painted stack region: its lowest word (`_stack_end`) and its word count, up to
/// `_stack_start` (cortex-m-rt's `paint-stack`; flip-link moves the region below the
/// statics).
fn stack_region() -> (*const u32, usize) {
    extern "C" {
        static _stack_end: u32;
        static _stack_start: u32;
    }
    let bottom = addr_of!(_stack_end);
    let top = addr_of!(_stack_start);
    (bottom, (top as usize).saturating_sub(bottom as usize) / 4)
}

/// Bytes of stack used since start-up ended: the painted stack region scanned from the
/// bottom for the first word the stack reached (`robot_app::stm32f4::stack`), after
/// [`repaint_after_start`] painted again what `init` used. Reads up to the whole region
/// (about 124 KiB): call it from the link task, not the control task.
pub fn stack_high_water_bytes() -> u32 {
    let (bottom, words) = stack_region();
    high_water_bytes((0..words).map(|i| {
        // SAFETY: `bottom + i` for `i < words` lies inside the stack region the linker
        // reserved (RAM, word-aligned: cortex-m-rt asserts both symbols' alignment);
        // volatile, because the compiler cannot know the stack writes to it.
        unsafe { bottom.add(i).read_volatile() }
    }))
}

/// Bytes of stack `init` used (start-up builds the application's state in its frame
/// before RTIC moves it into statics), measured once by [`repaint_after_start`].
static START_STACK_BYTES: AtomicU32 = AtomicU32::new(0);

/// Bytes of stack start-up used (see [`repaint_after_start`]).
#[cfg_attr(not(feature = "qemu"), allow(dead_code))]
pub fn start_stack_bytes() -> u32 {
    START_STACK_BYTES.load(Ordering::Relaxed)
}

/// Bytes kept unpainted below the stack pointer while repainting: room for this
/// function's own calls below its frame.
const REPAINT_MARGIN_BYTES: usize = 256;

/// Records the stack start-up used, then paints again the part of it below the idle
/// loop's stack pointer, so that [`stack_high_water_bytes`] measures the running tasks
/// (idle and the interrupts), which is what the stack must hold in operation. Call it
/// once, first thing in `idle`.
///
/// Interrupts stay on (the link's receive interrupt must never wait a character time for
/// it): `idle` is the lowest priority, so whenever one of its stores executes every
/// interrupt that preempted it has returned, and nothing below its stack pointer is live.
/// An interrupt taken between two stores pushes its frame there and pops it before the
/// next; a word it leaves written counts towards the high-water mark, as it should.
pub fn repaint_after_start() {
    let used = stack_high_water_bytes();
    START_STACK_BYTES.store(used, Ordering::Relaxed);
    let (bottom, words) = stack_region();
    let first = words.saturating_sub(used as usize / 4);
    let sp = cortex_m::register::msp::read() as usize;
    let limit = sp.saturating_sub(REPAINT_MARGIN_BYTES);
    for i in first..words {
        // SAFETY: `bottom + i` lies inside the stack region (as above), and below
        // `limit`, under every live frame (see the doc comment).
        let word = unsafe { bottom.add(i) } as *mut u32;
        if word as usize >= limit {
            break;
        }
        // SAFETY: see above; a plain word store.
        unsafe { word.write_volatile(PAINT) };
    }
}
