//! A guard on the firmware's task priorities (`firmware/src/main.rs`). USART2 holds one
//! received character and has no FIFO: at 230 400 Bd a character lasts 43.4 µs, and a
//! control step of 5 000 instructions lasts 60–75 µs, so the link USART's interrupt must
//! preempt every other task, the control interrupt included, or a long step loses a
//! byte. The control interrupt in turn preempts the steering task (the outer loop it
//! lends), which preempts the link task. QEMU never overruns a USART, so emulation
//! cannot show a wrong order; a test reads it from the source, and the stack bound
//! (`crate::panic_check`) nests the tasks by the same priorities.

use std::path::Path;

use anyhow::{bail, ensure, Context as _, Result};

/// The firmware's RTIC application, `firmware/src/main.rs` under the workspace `root`.
pub fn firmware_source(root: &Path) -> Result<String> {
    let path = root.join("firmware/src/main.rs");
    std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))
}

/// One RTIC hardware task: the interrupt it is bound to and its priority.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Task {
    /// The interrupt, as named in `binds = …`.
    pub binds: String,
    /// The RTIC priority (higher preempts lower).
    pub priority: u8,
}

/// Every `#[task(binds = X, priority = N, …)]` attribute in `source`.
pub fn tasks(source: &str) -> Result<Vec<Task>> {
    let mut tasks = Vec::new();
    for (number, line) in source.lines().enumerate() {
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
        tasks.push(Task { binds, priority });
    }
    Ok(tasks)
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
        assert_eq!(
            tasks(&source).unwrap().len(),
            5,
            "control, steering, plant port, USART, link"
        );
        check(&source).unwrap();
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
