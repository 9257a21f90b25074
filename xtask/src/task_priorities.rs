//! A guard on the firmware's task priorities (`firmware/src/main.rs`). USART2 holds one
//! received character and has no FIFO: at 230 400 Bd a character lasts 43.4 µs, and a
//! control step of 5 000 instructions lasts 60–75 µs, so the link USART's interrupt must
//! preempt every other task, the control interrupt included, or a long step loses a
//! byte. The control interrupt in turn preempts the steering task (the outer loop it
//! lends), which preempts the link task. QEMU never overruns a USART, so emulation
//! cannot show a wrong order; a test reads it from the source, and the stack bound
//! (`crate::panic_check`) nests the tasks by the same priorities.
//!
//! RTIC 2 sets the priority of and unmasks every interrupt a hardware task binds before
//! `init`, even when a `#[cfg]` compiles the task out, so an interrupt bound only for the
//! qemu board (its plant port on USART1) would be enabled on the F411 with no handler of
//! its own. The F411 board masks it again in `init`: a second check ([`check_f411_masks`])
//! holds the board's `UNUSED_INTERRUPTS` to exactly the interrupts of the tasks the F411
//! build leaves out.

use std::path::Path;

use anyhow::{bail, ensure, Context as _, Result};

/// The firmware's RTIC application, `firmware/src/main.rs` under the workspace `root`.
pub fn firmware_source(root: &Path) -> Result<String> {
    let path = root.join("firmware/src/main.rs");
    std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))
}

/// The F411 board's module, `firmware/src/board/f411/mod.rs` under the workspace `root`.
pub fn f411_board_source(root: &Path) -> Result<String> {
    let path = root.join("firmware/src/board/f411/mod.rs");
    std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))
}

/// One RTIC hardware task: the interrupt it is bound to, its priority, and the board it
/// is compiled for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Task {
    /// The interrupt, as named in `binds = …`.
    pub binds: String,
    /// The RTIC priority (higher preempts lower).
    pub priority: u8,
    /// Compiled only with the `qemu` feature (a `#[cfg(feature = "qemu")]` line right
    /// above the attribute).
    pub qemu_only: bool,
}

/// The cfg that keeps a task to the emulated board.
const QEMU_ONLY: &str = "#[cfg(feature = \"qemu\")]";

/// Every `#[task(binds = X, priority = N, …)]` attribute in `source`.
pub fn tasks(source: &str) -> Result<Vec<Task>> {
    let mut tasks = Vec::new();
    let mut previous = "";
    for (number, line) in source.lines().enumerate() {
        let above = std::mem::replace(&mut previous, line.trim());
        let Some(attribute) = line.trim().strip_prefix("#[task(") else {
            continue;
        };
        let value = |key: &str| {
            attribute.split(',').find_map(|part| {
                let (k, v) = part.split_once('=')?;
                (k.trim() == key).then(|| v.trim().trim_end_matches(")]").to_string())
            })
        };
        let binds = value("binds").with_context(|| format!("line {}: no `binds`", number + 1))?;
        let priority = value("priority")
            .with_context(|| format!("line {}: no `priority`", number + 1))?
            .parse()
            .with_context(|| format!("line {}: the priority is not a number", number + 1))?;
        tasks.push(Task {
            binds,
            priority,
            qemu_only: above == QEMU_ONLY,
        });
    }
    Ok(tasks)
}

/// The interrupts listed in the `UNUSED_INTERRUPTS` constant of `board`, the F411 board's
/// source (`[pac::Interrupt; N] = [pac::Interrupt::USART1, …]`).
pub fn unused_interrupts(board: &str) -> Result<Vec<String>> {
    let start = board
        .find("pub const UNUSED_INTERRUPTS")
        .context("the F411 board has no `UNUSED_INTERRUPTS`")?;
    let value = board[start..]
        .split_once('=')
        .and_then(|(_, rest)| rest.split_once(';'))
        .map(|(value, _)| value)
        .context("`UNUSED_INTERRUPTS` has no value")?;
    Ok(value
        .split(['[', ']', ','])
        .filter_map(|item| item.trim().strip_prefix("pac::Interrupt::"))
        .map(str::to_string)
        .collect())
}

/// The F411 board masks exactly the interrupts of the tasks its build leaves out (module
/// doc).
pub fn check_f411_masks(app: &str, board: &str) -> Result<()> {
    let mut left_out: Vec<String> = tasks(app)?
        .into_iter()
        .filter(|t| t.qemu_only)
        .map(|t| t.binds)
        .collect();
    let mut masked = unused_interrupts(board)?;
    left_out.sort();
    masked.sort();
    ensure!(
        left_out == masked,
        "the F411 board masks {masked:?} in init, but the tasks its build leaves out bind \
         {left_out:?}: RTIC enables those anyway"
    );
    Ok(())
}

/// Checks the order of the module doc (the test below runs it on the firmware): USART2 above every other task, TIM5 (control)
/// above EXTI3 (steering), EXTI3 above EXTI4 (the link task).
pub fn check(source: &str) -> Result<()> {
    let tasks = tasks(source)?;
    let priority = |binds: &str| {
        tasks
            .iter()
            .find(|t| t.binds == binds)
            .map(|t| t.priority)
            .with_context(|| format!("no task bound to {binds}"))
    };
    let usart = priority("USART2")?;
    if let Some(other) = tasks
        .iter()
        .find(|t| t.binds != "USART2" && t.priority >= usart)
    {
        bail!(
            "the link USART's interrupt (priority {usart}) must preempt every other task; \
             {} has priority {}",
            other.binds,
            other.priority
        );
    }
    let (control, steering, link) = (priority("TIM5")?, priority("EXTI3")?, priority("EXTI4")?);
    ensure!(
        control > steering && steering > link,
        "expected control (TIM5) > steering (EXTI3) > link task (EXTI4), found {control}, \
         {steering}, {link}"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_firmware_s_priorities_put_the_link_usart_above_the_control_interrupt() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let source = firmware_source(&root).unwrap();
        let tasks = tasks(&source).unwrap();
        assert_eq!(tasks.len(), 5, "control, steering, plant port, USART, link");
        check(&source).unwrap();
        let qemu_only: Vec<&str> = tasks
            .iter()
            .filter(|t| t.qemu_only)
            .map(|t| t.binds.as_str())
            .collect();
        assert_eq!(qemu_only, ["USART1"], "the plant port");
    }

    #[test]
    fn the_f411_build_masks_the_interrupt_its_left_out_task_binds() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let app = firmware_source(&root).unwrap();
        let board = f411_board_source(&root).unwrap();
        assert_eq!(unused_interrupts(&board).unwrap(), ["USART1"]);
        check_f411_masks(&app, &board).unwrap();
    }

    #[test]
    fn a_left_out_task_the_board_does_not_mask_is_refused() {
        let app = "#[task(binds = TIM5, priority = 3, local = [io])]\n\
                   #[cfg(feature = \"qemu\")]\n\
                   #[task(binds = USART1, priority = 3, local = [plant])]\n\
                   #[cfg(feature = \"qemu\")]\n\
                   #[task(binds = UART4, priority = 2)]\n";
        let board =
            |list: &str| format!("pub const UNUSED_INTERRUPTS: [pac::Interrupt; 2] = [{list}];\n");
        check_f411_masks(app, &board("pac::Interrupt::UART4, pac::Interrupt::USART1")).unwrap();
        let err = check_f411_masks(app, &board("pac::Interrupt::USART1"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("UART4"), "{err}");
        // Masking one that the build does use is refused too.
        assert!(check_f411_masks(
            app,
            &board("pac::Interrupt::UART4, pac::Interrupt::USART1, pac::Interrupt::TIM5")
        )
        .is_err());
        assert!(check_f411_masks(app, "no list here").is_err());
    }

    #[test]
    fn a_link_usart_at_or_below_another_task_is_refused() {
        let app = |usart: u8, control: u8| {
            format!(
                "#[task(binds = TIM5, priority = {control}, local = [io])]\n\
                 #[task(binds = EXTI3, priority = 2, local = [steering])]\n\
                 #[task(binds = USART2, priority = {usart}, local = [uart])]\n\
                 #[task(binds = EXTI4, priority = 1, shared = [watchdog], local = [link])]\n"
            )
        };
        check(&app(4, 3)).unwrap();
        let err = check(&app(3, 3)).unwrap_err().to_string();
        assert!(err.contains("TIM5 has priority 3"), "{err}");
        assert!(check(&app(2, 3)).is_err());
        // The steering task above the control interrupt is refused too.
        assert!(check(&app(4, 2)).is_err());
        assert!(check("#[task(binds = TIM5)]").is_err(), "no priority");
    }
}
