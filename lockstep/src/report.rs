//! The board's figures at the end of a run: every task's runs, longest run and total.

use crate::wire::{Parse, Reader, Writer};
use crate::{BOARD_REPORT_LEN, FINISH};

/// The board's figures at the end of a run (answer to [`FINISH`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BoardReport {
    /// The control interrupt's runs, every step, in any state.
    pub control: TaskFigures,
    /// The control interrupt's runs in the armed steady state: the steps that end armed
    /// and report no event.
    pub control_armed: TaskFigures,
    /// The control interrupt's runs in the steps that arm (in motion or not).
    pub control_arming: TaskFigures,
    /// The steering task's runs (the outer loop lent by the control interrupt).
    pub steering: TaskFigures,
    /// The link task's runs.
    pub link: TaskFigures,
    /// The link USART interrupt's runs (above every other task).
    pub link_uart: TaskFigures,
    /// The stack's high-water mark while the application ran (after start-up), bytes.
    pub stack_high_water_bytes: u32,
    /// The stack start-up (`init`) used, bytes.
    pub start_stack_bytes: u32,
}

/// One task's runs, in instructions of its own time (counted with SysTick under QEMU's
/// `-icount`; the firmware leaves out what higher-priority tasks spent preempting it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TaskFigures {
    /// Runs recorded.
    pub runs: u32,
    /// The longest run, instructions.
    pub max_instructions: u32,
    /// All runs together, instructions (saturating at `u32::MAX`).
    pub total_instructions: u32,
}

impl TaskFigures {
    /// The mean run, instructions (0 without a run).
    pub fn mean_instructions(&self) -> f64 {
        if self.runs == 0 {
            0.0
        } else {
            f64::from(self.total_instructions) / f64::from(self.runs)
        }
    }
}

impl BoardReport {
    /// The message's bytes.
    pub fn encode(&self) -> [u8; BOARD_REPORT_LEN] {
        let mut out = [0u8; BOARD_REPORT_LEN];
        let mut w = Writer {
            out: &mut out,
            at: 0,
        };
        w.u8(FINISH);
        for task in [
            &self.control,
            &self.control_armed,
            &self.control_arming,
            &self.steering,
            &self.link,
            &self.link_uart,
        ] {
            w.u32(task.runs);
            w.u32(task.max_instructions);
            w.u32(task.total_instructions);
        }
        w.u32(self.stack_high_water_bytes);
        w.u32(self.start_stack_bytes);
        out
    }

    pub(crate) fn parse(bytes: &[u8]) -> Parse<Self> {
        let mut r = Reader { bytes, at: 1 };
        Parse::read((|| {
            let mut task = || {
                Some(TaskFigures {
                    runs: r.u32()?,
                    max_instructions: r.u32()?,
                    total_instructions: r.u32()?,
                })
            };
            let (control, control_armed, control_arming, steering, link, link_uart) =
                (task()?, task()?, task()?, task()?, task()?, task()?);
            Some(Self {
                control,
                control_armed,
                control_arming,
                steering,
                link,
                link_uart,
                stack_high_water_bytes: r.u32()?,
                start_stack_bytes: r.u32()?,
            })
        })())
    }
}
