//! The first-flash programs (`firmware/examples/`, `docs/first-flash.md`): each is built
//! for the F411 with the firmware's profile and its flash and static RAM printed; `hello`
//! is also built for the emulated board (`--features qemu`) and run under
//! `qemu-system-arm` (netduinoplus2, semihosting), which must exit with status 0 after
//! printing its report line, `hello under QEMU: reset cause …, clock …`.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context as _, Result};

use crate::elf_size::{sections, MemoryUse};
use crate::qemu::run_qemu;
use crate::steps::{build_target_artifacts, Context};

/// The programs, in the order a new board meets them.
pub const PROGRAMS: [&str; 4] = ["hello", "encoders", "motors", "supply"];

/// How `hello`'s report under QEMU starts.
const QEMU_REPORT: &str = "hello under QEMU: ";

/// The CI step (see the module doc).
pub fn check(ctx: &Context) -> Result<()> {
    let built = build_target_artifacts(ctx, "firmware", &["--examples"], "example")?;
    for program in PROGRAMS {
        let elf = named(&built, program)?;
        let data = std::fs::read(elf).with_context(|| format!("reading {}", elf.display()))?;
        let usage = MemoryUse::of(sections(&data)?);
        println!(
            "first-flash program {program}: flash {} B, static RAM {} B",
            usage.flash, usage.ram
        );
    }

    let emulated = build_target_artifacts(
        ctx,
        "firmware",
        &["--example", "hello", "--features", "qemu"],
        "example",
    )?;
    let output = run_qemu(named(&emulated, "hello")?)?;
    println!("{}", hello_report(&output)?);
    Ok(())
}

/// The executable called `name` among `built`.
fn named<'a>(built: &'a [PathBuf], name: &str) -> Result<&'a Path> {
    built
        .iter()
        .find(|path| path.file_name().is_some_and(|n| n == name))
        .map(PathBuf::as_path)
        .with_context(|| format!("the build produced no `{name}` program (got {built:?})"))
}

/// `hello`'s report line in QEMU's `output`: the one that starts with
/// `hello under QEMU: ` and names the reset cause and the clock.
fn hello_report(output: &str) -> Result<&str> {
    let Some(line) = output
        .lines()
        .map(str::trim)
        .find(|line| line.starts_with(QEMU_REPORT))
    else {
        bail!("hello printed no `{QEMU_REPORT}…` line under QEMU");
    };
    for field in ["reset cause ", "clock "] {
        if !line.contains(field) {
            bail!("hello's report names no `{}`: {line:?}", field.trim_end());
        }
    }
    Ok(line)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_line_is_found_and_checked() {
        let output = "board: …\nhello under QEMU: reset cause Unknown, clock simulated, chip X\n";
        assert_eq!(
            hello_report(output).unwrap(),
            "hello under QEMU: reset cause Unknown, clock simulated, chip X"
        );
        let silent = hello_report("something else\n").unwrap_err().to_string();
        assert!(silent.contains("no `hello under QEMU: …` line"), "{silent}");
        let no_clock = hello_report("hello under QEMU: reset cause Unknown\n")
            .unwrap_err()
            .to_string();
        assert!(no_clock.contains("`clock`"), "{no_clock}");
    }

    #[test]
    fn the_page_shows_how_to_flash_every_program() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let page = std::fs::read_to_string(root.join("docs/first-flash.md")).unwrap();
        let config = std::fs::read_to_string(root.join(".cargo/config.toml")).unwrap();
        assert!(
            config.contains("\nfw-example = \"run --profile firmware --package firmware"),
            ".cargo/config.toml has no `fw-example` alias"
        );
        for program in PROGRAMS {
            assert!(
                page.contains(&format!("\n## `{program}`")),
                "docs/first-flash.md has no section for `{program}`"
            );
            assert!(
                page.contains(&format!("cargo fw-example {program}\n")),
                "docs/first-flash.md does not show `cargo fw-example {program}`"
            );
        }
    }

    #[test]
    fn every_program_has_its_example_target() {
        let manifest = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/Cargo.toml"),
        )
        .unwrap();
        for program in PROGRAMS {
            assert!(
                manifest.contains(&format!("[[example]]\nname = \"{program}\"")),
                "firmware/Cargo.toml has no example `{program}`"
            );
            let source = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join(format!("../firmware/examples/{program}.rs"));
            assert!(source.exists(), "{}", source.display());
        }
    }
}
