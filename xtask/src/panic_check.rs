//! `cargo xtask panic-check`: proof, from the release ELF, that the control interrupt
//! cannot panic.
//!
//! From each root interrupt's handler (its vector table entry) the check follows every
//! direct call (`BL`) and every branch that leaves a function (tail calls), decoding the
//! Thumb-2 code of each function it reaches between the symbol's start and end and
//! skipping what the ARM mapping symbols mark as data (literal pools, `TBB`/`TBH`
//! tables). It fails when
//!
//! - a panic function is reachable: the `#[panic_handler]` (`rust_begin_unwind`) or a
//!   `core` function that only leads there (`core::panicking::*`, `unwrap_failed`, slice
//!   index failures, see [`panic_names`]); every such call site is printed with the chain
//!   of calls from the root, one function a line;
//! - an indirect transfer leaves the analysis (`BLX Rm`, `BX Rm` other than `BX LR`,
//!   `MOV`/`ADD PC, Rm`, `LDR PC` / `LDM {…, PC}` other than a pop): its target is unknown,
//!   so the check cannot vouch for it;
//! - code cannot be decoded, or a call goes to an address that is in no function.
//!
//! Panic functions are not explored further: what runs after a panic (the handler's
//! logging) is not the interrupt's concern. Functions the interrupt does not call but
//! *triggers* (an RTIC `spawn` pends the dispatcher interrupt) run in their own handler,
//! which is a root of its own if it must not panic. `UDF` traps (after calls that cannot
//! return) are not panics and are not reported.
//!
//! A panic path is one call instruction. The optimiser may merge the panics of several
//! source lines into one call (DWARF then gives line `?` or one of them), so fixing the
//! reported line can bring the next one to light: run the check again until it passes.
//! The source lines under each call site come from the ELF's DWARF, inlined frames
//! innermost first; they are for the reader, the proof does not use them.
//!
//! The CI step also builds the firmware with the test-only feature `panic-canary`, which
//! adds one bounds-checked indexing in a function the control task calls, and requires
//! the check to find it: a check that cannot see that panic path would pass anything.
//!
//! The same call graph bounds the firmware's stack ([`mod@stack_bound`]): each function's
//! frame is what its instructions push or subtract from SP, each task's worst case its
//! deepest chain, and tasks of different priorities add up, each with an exception
//! frame. Unlike the high-water mark that processor in the loop measures, the bound does
//! not depend on when interrupts happen to arrive.

mod call_graph;
mod image;
mod panic_names;
mod report;
mod source_lines;
mod stack_bound;
#[cfg(test)]
mod test_support;
mod thumb;

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::{bail, ensure, Context as _, Result};

use self::image::{FunctionId, Image};
use self::report::Findings;
use self::source_lines::SourceLines;
use crate::steps::{build_target_executables, Context};

/// The limit on the call-graph bound of the firmware's stack, bytes. It over-counts (every
/// priority level's deepest chain at once); the measured high-water mark has its own,
/// lower limit (`crate::pil::STACK_LIMIT`).
pub const STACK_BOUND_LIMIT: u64 = 6 * 1024;

/// Vector table entry of IRQ 0: the 16 system exception entries come first.
const FIRST_IRQ_ENTRY: u32 = 16;

/// The firmware feature that adds a known panic path to the control task (test only).
pub const CANARY_FEATURE: &str = "panic-canary";
/// The firmware function that holds the canary's panic path (`firmware/src/panic_canary.rs`).
pub const CANARY_FUNCTION: &str = "firmware::panic_canary::index";

/// An interrupt whose handler must not be able to panic.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Root {
    /// What the interrupt is for, for the report (`control interrupt`).
    pub role: String,
    /// The interrupt's name. cortex-m-rt (and so RTIC) names the handler function after
    /// it (`TIM5`), and the check requires the vector to point at that function.
    pub name: String,
    /// IRQ number (NVIC position): the handler is vector table entry 16 + `irq`.
    pub irq: u32,
}

impl Root {
    /// The firmware's control task: bound to TIM5's update interrupt, IRQ 50 on the
    /// STM32F4 (RM0383, table 37).
    pub fn control_interrupt() -> Self {
        Self {
            role: "control interrupt".into(),
            name: "TIM5".into(),
            irq: 50,
        }
    }

    /// The link's USART: its receive and transmit interrupt, USART2, IRQ 38 on the
    /// STM32F4 (RM0383, table 37). It runs above the link task, so it must not panic
    /// either.
    pub fn link_usart_interrupt() -> Self {
        Self {
            role: "link USART interrupt".into(),
            name: "USART2".into(),
            irq: 38,
        }
    }

    /// The steering task: the outer loop the control task lends it, run below the control
    /// task between two steps. Bound to EXTI line 3, IRQ 9 on the STM32F4 (RM0383, table
    /// 37), which only software pends. It ran in the control interrupt before it was
    /// lent, and must not panic either.
    pub fn steering_task() -> Self {
        Self {
            role: "steering task".into(),
            name: "EXTI3".into(),
            irq: 9,
        }
    }

    /// A root from `NAME:IRQ` (`USART2:38`).
    pub fn parse(spec: &str) -> Result<Self> {
        let (name, irq) = spec
            .split_once(':')
            .with_context(|| format!("root `{spec}`: expected NAME:IRQ, e.g. TIM5:50"))?;
        let irq = irq
            .parse()
            .with_context(|| format!("root `{spec}`: IRQ `{irq}` is not a number"))?;
        ensure!(!name.is_empty(), "root `{spec}`: empty interrupt name");
        Ok(Self {
            role: "interrupt".into(),
            name: name.into(),
            irq,
        })
    }

    /// Its vector table entry.
    fn vector_entry(&self) -> u32 {
        FIRST_IRQ_ENTRY + self.irq
    }
}

impl fmt::Display for Root {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} (IRQ {})", self.role, self.name, self.irq)
    }
}

/// The F411 firmware's tasks with their priorities, as `firmware/src/main.rs` (under
/// `root`, the workspace) binds them, after checking their order
/// ([`crate::task_priorities::check`]): one source of truth for the order the stack bound
/// nests them in. The qemu board's plant port (USART1) is not in the F411 build, whose
/// board masks its interrupt again (checked too: [`crate::task_priorities::check_f411_masks`]).
pub fn firmware_tasks(root: &Path) -> Result<Vec<(Root, u8)>> {
    let source = crate::task_priorities::firmware_source(root)?;
    crate::task_priorities::check(&source)?;
    crate::task_priorities::check_f411_masks(
        &source,
        &crate::task_priorities::f411_board_source(root)?,
    )?;
    let tasks = crate::task_priorities::tasks(&source)?;
    let priority = |binds: &str| {
        tasks
            .iter()
            .find(|t| t.binds == binds)
            .map(|t| t.priority)
            .with_context(|| format!("firmware/src/main.rs binds no task to {binds}"))
    };
    Ok(vec![
        (
            Root {
                role: "link task".into(),
                name: "EXTI4".into(),
                irq: 10,
            },
            priority("EXTI4")?,
        ),
        (Root::steering_task(), priority("EXTI3")?),
        (Root::control_interrupt(), priority("TIM5")?),
        (Root::link_usart_interrupt(), priority("USART2")?),
    ])
}

/// Bytes the Cortex-M4F stacks on exception entry with an active floating-point
/// context (26 words: R0–R3, R12, LR, PC, xPSR, S0–S15, FPSCR and a reserved word),
/// plus 4 for the 8-byte alignment (ARMv7-M B1.5.7).
pub const EXCEPTION_FRAME_BYTES: u32 = 108;

/// Thread mode, under every task: the function the reset handler calls, whose frame
/// stays while RTIC's idle task runs inside it, and the idle task. (RTIC's `init` runs
/// in it too, but with interrupts disabled, and has returned before idle starts.)
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ThreadMode {
    /// The entry function's name (`main`).
    pub main: String,
    /// The idle task's function (`firmware::app::idle`).
    pub idle: String,
}

impl ThreadMode {
    /// The firmware's: RTIC's `main`, and its `idle` in the `app` module.
    pub fn firmware() -> Self {
        Self {
            main: "main".into(),
            idle: "firmware::app::idle".into(),
        }
    }
}

/// The firmware's worst-case stack from its call graph, bytes: thread mode's (`main`'s
/// frame and the idle task's deepest chain), then for each priority level the deepest
/// task's chain plus an exception frame, summed over the levels (each can preempt the
/// one below at its deepest). Prints each part's bound and chain. Fails if a part's
/// stack has no bound.
pub fn stack_bound(image: &Image, thread: &ThreadMode, tasks: &[(Root, u8)]) -> Result<u32> {
    let named = |name: &str| {
        image
            .find_function(|n| n == name)
            .with_context(|| format!("thread mode: no function `{name}`"))
    };
    let main = named(&thread.main)?;
    // Only `main`'s own frame: what it calls before idle (`init`) has returned by then.
    let main_frame = call_graph::explore(image, main, is_panic)
        .frames
        .get(&main)
        .map_or(0, |f| f.bytes);
    let idle = deepest_chain(image, named(&thread.idle)?, "the idle task")?;
    let thread_bytes = main_frame + idle;
    println!(
        "stack bound of thread mode: {thread_bytes} bytes (the idle task in {}'s frame, \
         {main_frame} B)",
        thread.main
    );
    let mut by_priority: std::collections::BTreeMap<u8, u32> = Default::default();
    for (root, priority) in tasks {
        let bytes = deepest_chain(
            image,
            handler(image, root)?,
            &format!("the {root}, priority {priority}"),
        )?;
        let level = by_priority.entry(*priority).or_default();
        *level = (*level).max(bytes);
    }
    Ok(thread_bytes
        + by_priority
            .values()
            .map(|bytes| bytes + EXCEPTION_FRAME_BYTES)
            .sum::<u32>())
}

/// The deepest chain from `id` (a task's entry), bytes; prints it under `what`.
fn deepest_chain(image: &Image, id: FunctionId, what: &str) -> Result<u32> {
    let exploration = call_graph::explore(image, id, is_panic);
    let (bytes, chain) = stack_bound::worst_case(&exploration, |f| is_panic(image.function(f)))
        .map_err(|why| {
            let name = |f: FunctionId| image.function(f).name.clone();
            let why = match why {
                stack_bound::Unbounded::Dynamic(f) => {
                    format!("{} lowers SP by a register's value", name(f))
                }
                stack_bound::Unbounded::Recursion(cycle) => format!(
                    "recursion: {}",
                    cycle.into_iter().map(name).collect::<Vec<_>>().join(" -> ")
                ),
                stack_bound::Unbounded::LeavesAnalysis => {
                    "a transfer the analysis cannot follow (run the panic check on it)".to_string()
                }
            };
            anyhow::anyhow!("{what}: no stack bound: {why}")
        })?;
    println!("stack bound of {what}: {bytes} bytes, deepest through");
    for f in chain {
        let frame = exploration.frames.get(&f).map_or(0, |fr| fr.bytes);
        println!("    {frame:>5} B  {}", image.function(f).name);
    }
    Ok(bytes)
}

/// Whether the analysis stops at `f`: a panic function ([`panic_names`]).
fn is_panic(f: &image::Function) -> bool {
    panic_names::is_panic_function(&f.name)
}

/// The roots `cargo xtask panic-check` checks when none are given.
pub fn default_roots() -> Vec<Root> {
    vec![
        Root::control_interrupt(),
        Root::steering_task(),
        Root::link_usart_interrupt(),
    ]
}

/// Explores the image from each root; `lines` adds source lines to the report.
fn analyze<'a>(
    image: &'a Image,
    roots: &'a [Root],
    lines: Option<&'a SourceLines<'a>>,
) -> Result<Vec<Findings<'a>>> {
    // Without a panic handler symbol a chain could end somewhere the names do not know.
    ensure!(
        image.find_function(panic_names::is_panic_handler).is_some(),
        "no panic handler (`rust_begin_unwind`) among the function symbols"
    );
    roots
        .iter()
        .map(|root| {
            let id = handler(image, root)?;
            let exploration = call_graph::explore(image, id, is_panic);
            Ok(Findings {
                root,
                image,
                exploration,
                lines,
            })
        })
        .collect()
}

/// The handler function of `root`: the one its vector table entry points at, which must
/// be named after the interrupt.
fn handler(image: &Image, root: &Root) -> Result<FunctionId> {
    let entry = root.vector_entry();
    let handler = image
        .vector(entry)
        .with_context(|| format!("{root}: vector table entry {entry}"))?;
    let id = image
        .function_containing(handler)
        .filter(|&id| image.function(id).addr == handler)
        .with_context(|| {
            format!("{root}: vector entry {entry} is {handler:#010x}, where no function starts")
        })?;
    let function = image.function(id);
    ensure!(
        function.name == root.name,
        "{root}: vector entry {entry} points at {function}, not at a handler named {}: \
         is the task still bound to {}?",
        root.name,
        root.name
    );
    Ok(id)
}

/// Checks the ELF at `path` from every root: prints the reachable functions, every panic
/// path and problem (with source lines, file names relative to `workspace`), and one
/// verdict line per root. Fails unless every root is clean.
pub fn check_elf(path: &Path, roots: &[Root], workspace: &Path) -> Result<()> {
    let data = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let image = Image::parse(&data).with_context(|| format!("reading {}", path.display()))?;
    println!("{}:", path.display());
    let lines = match SourceLines::parse(&data, workspace) {
        Ok(lines) => Some(lines),
        Err(e) => {
            println!("(no source lines in this report: {e:#})");
            None
        }
    };
    let findings = analyze(&image, roots, lines.as_ref())?;
    for f in &findings {
        print!("{}", f.reachable());
        print!("{}", f.details());
    }
    for f in &findings {
        println!("{}", f.verdict());
    }
    let failed: Vec<_> = findings
        .iter()
        .filter(|f| !f.is_clean())
        .map(|f| f.root.name.as_str())
        .collect();
    if !failed.is_empty() {
        bail!(
            "{} can panic or leave the analysis (see above)",
            failed.join(", ")
        );
    }
    Ok(())
}

/// The CI step: the canary build must fail the check, then the default release build
/// must pass it, from the control interrupt.
pub fn check_firmware(ctx: &Context) -> Result<()> {
    let roots = default_roots();

    // The canary first: both builds are copied to the same path (target/…/release/
    // firmware), and the one left there afterwards should be the real firmware.
    let canary = build_firmware(ctx, &["--features", CANARY_FEATURE])?;
    let image = Image::load(&canary)?;
    let findings = analyze(&image, &roots, None)?;
    for f in &findings {
        println!("`{CANARY_FEATURE}` build, {}", f.verdict());
    }
    ensure!(
        findings
            .iter()
            .any(|f| f.has_panic_site_in(CANARY_FUNCTION)),
        "the check did not find the panic path that the `{CANARY_FEATURE}` build adds in \
         {CANARY_FUNCTION}: a check that cannot see it would pass anything"
    );
    println!("the canary's panic path in {CANARY_FUNCTION} was found, as it must be\n");

    let firmware = build_firmware(ctx, &[])?;
    check_elf(&firmware, &roots, &ctx.root)?;

    println!();
    let image = Image::load(&firmware)?;
    let bound = stack_bound(&image, &ThreadMode::firmware(), &firmware_tasks(&ctx.root)?)?;
    println!(
        "stack worst case (call graph): {bound} bytes (thread mode, then each priority's \
         deepest task, nested, with a {EXCEPTION_FRAME_BYTES}-byte exception frame each); \
         limit {STACK_BOUND_LIMIT} bytes"
    );
    ensure!(
        u64::from(bound) <= STACK_BOUND_LIMIT,
        "the stack's worst case is {bound} bytes > {STACK_BOUND_LIMIT}"
    );
    Ok(())
}

/// Release-builds the firmware with `features` (cargo arguments) and returns its ELF.
fn build_firmware(ctx: &Context, features: &[&str]) -> Result<PathBuf> {
    match build_target_executables(ctx, "firmware", features)?.as_slice() {
        [one] => Ok(one.clone()),
        other => bail!("expected one firmware executable, the build produced {other:?}"),
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::*;
    use super::*;

    fn root(spec: &str) -> Root {
        Root::parse(spec).unwrap()
    }

    #[test]
    fn tasks_of_different_priorities_add_up_and_of_one_priority_do_not() {
        // Three handlers: TIM5 (IRQ 50) 8 + 100 bytes, USART2 (IRQ 38) 8 + 40, EXTI4
        // (IRQ 10) 8 + 20; each `push {r7, lr}` then `sub sp, #n`. Thread mode: `main`,
        // 8 + 12, calls `init` (8 + 400, returned before the tasks run) and then `idle`,
        // 8 + 4.
        let mut asm = Assembler::default();
        for (name, irq, at, bytes) in [
            ("TIM5", 50u32, BASE + 0x100, 100u16),
            ("USART2", 38, BASE + 0x200, 40),
            ("EXTI4", 10, BASE + 0x300, 20),
        ] {
            asm.function(name, at, &[PUSH_R7_LR, 0xb080 | (bytes / 4), POP_R7_PC]);
            asm.vector(FIRST_IRQ_ENTRY + irq, at);
        }
        asm.function("rust_begin_unwind", BASE + 0x400, &[BX_LR]);
        asm.function("init", BASE + 0x500, &[PUSH_R7_LR, 0xb080 | 100, POP_R7_PC]);
        asm.function("idle", BASE + 0x600, &[PUSH_R7_LR, 0xb081, POP_R7_PC]);
        let [init_hi, init_lo] = wide_branch(BASE + 0x704, BASE + 0x500, true);
        let [idle_hi, idle_lo] = wide_branch(BASE + 0x708, BASE + 0x600, true);
        asm.function(
            "main",
            BASE + 0x700,
            &[
                PUSH_R7_LR, 0xb083, init_hi, init_lo, idle_hi, idle_lo, POP_R7_PC,
            ],
        );
        let image = asm.image();
        let thread = ThreadMode {
            main: "main".into(),
            idle: "idle".into(),
        };
        let tasks = |priorities: [u8; 3]| {
            let roots = [
                root("EXTI4:10"),
                Root::link_usart_interrupt(),
                Root::control_interrupt(),
            ];
            roots.into_iter().zip(priorities).collect::<Vec<_>>()
        };
        let frame = EXCEPTION_FRAME_BYTES;
        let thread_mode = 20 + 12;
        assert_eq!(
            stack_bound(&image, &thread, &tasks([1, 2, 3])).unwrap(),
            thread_mode + (28 + frame) + (48 + frame) + (108 + frame)
        );
        // USART2 and TIM5 at one priority cannot preempt each other: the deeper counts.
        assert_eq!(
            stack_bound(&image, &thread, &tasks([1, 2, 2])).unwrap(),
            thread_mode + (28 + frame) + (108 + frame)
        );
        // An image without the thread-mode functions has no bound.
        let missing = ThreadMode {
            main: "main".into(),
            idle: "app::idle".into(),
        };
        assert!(stack_bound(&image, &missing, &tasks([1, 2, 3])).is_err());
    }

    #[test]
    fn a_panic_path_is_printed_from_the_root_one_function_a_line() {
        let image = program().image();
        let roots = [Root::control_interrupt(), root("USART2:38")];
        let findings = analyze(&image, &roots, None).unwrap();

        let [control, link] = &findings[..] else {
            panic!("two roots, two findings");
        };
        assert!(!control.is_clean());
        assert_eq!(
            control.verdict(),
            "control interrupt TIM5 (IRQ 50): 5 functions reachable, 1 panic path, \
             no indirect call"
        );
        assert_eq!(
            control.details(),
            "panic path 1 of 1: core::panicking::panic_bounds_check\n\
             \x20   0x08000100  TIM5\n\
             \x20   0x08000300  middle  (bl at 0x08000106)\n\
             \x20   0x08000400  tail  (b at 0x08000302)\n\
             \x20   0x08000500  core::panicking::panic_bounds_check  (bl at 0x08000400)\n"
        );
        assert!(control.has_panic_site_in("tail"));
        assert!(!control.has_panic_site_in("middle"));

        assert!(link.is_clean());
        assert_eq!(
            link.verdict(),
            "interrupt USART2 (IRQ 38): 2 functions reachable, no panic path, no indirect call"
        );
        assert_eq!(link.details(), "");
    }

    #[test]
    fn indirect_calls_fail_the_root_and_are_named() {
        let image = program().image();
        let roots = [root("unreachable:7")];
        let findings = analyze(&image, &roots, None).unwrap();
        let only = &findings[0];
        assert_eq!(
            only.verdict(),
            "interrupt unreachable (IRQ 7): 2 functions reachable, 1 panic path, \
             1 indirect call"
        );
        assert!(only.details().contains(
            "indirect call `blx r3` at 0x08000600 in unreachable: its target is unknown\n\
             \x20   0x08000600  unreachable\n"
        ));
    }

    #[test]
    fn a_root_must_be_bound_to_its_handler() {
        let image = program().image();
        // IRQ 7's vector points at `unreachable`, not at a function named EXTI1.
        let error = analyze(&image, &[root("EXTI1:7")], None).err().unwrap();
        assert!(
            format!("{error:#}").contains("not at a handler named EXTI1"),
            "{error:#}"
        );
        // IRQ 3's vector is empty (no Thumb bit); IRQ 60's lies past the table.
        assert!(analyze(&image, &[root("EXTI3:3")], None).is_err());
        assert!(analyze(&image, &[root("DMA2:60")], None).is_err());
    }

    #[test]
    fn an_image_without_a_panic_handler_is_refused() {
        let mut asm = program();
        asm.functions
            .retain(|f| !f.name.ends_with("rust_begin_unwind"));
        let image = asm.image();
        let error = analyze(&image, &[Root::control_interrupt()], None)
            .err()
            .unwrap();
        assert!(format!("{error}").contains("no panic handler"), "{error}");
    }

    #[test]
    fn roots_from_the_command_line() {
        let root = Root::parse("USART2:38").unwrap();
        assert_eq!((root.name.as_str(), root.irq), ("USART2", 38));
        assert_eq!(root.vector_entry(), 54);
        assert_eq!(Root::control_interrupt().vector_entry(), 66);
        assert!(Root::parse("TIM5").is_err());
        assert!(Root::parse("TIM5:fifty").is_err());
        assert!(Root::parse(":50").is_err());
    }
}
