//! A Python virtual environment under `target/venvs/NAME` with pinned packages from
//! PyPI, for the checks that read this project's output with code nobody here wrote.
//! Made once and kept: it is made again only when its requirements change (they are
//! written into it) or its interpreter is gone.

use std::path::PathBuf;
use std::process::Command;

use anyhow::{ensure, Context as _, Result};

use crate::steps::{display_command, Context};

/// The interpreter of the environment `name` holding `requirements` (pip's
/// `package==version` lines), made or brought up to date first.
pub fn venv_python(ctx: &Context, name: &str, requirements: &[&str]) -> Result<PathBuf> {
    let dir = crate::pil::target_dir(ctx).join("venvs").join(name);
    let python = dir.join("bin").join("python");
    let marker = dir.join("requirements.txt");
    let wanted = requirements.join("\n") + "\n";
    if python.is_file() && std::fs::read_to_string(&marker).is_ok_and(|m| m == wanted) {
        println!(
            "venv {name}: {} ({})",
            dir.display(),
            requirements.join(", ")
        );
        return Ok(python);
    }
    let system = crate::setup::ensure_python3()?;
    let mut make = Command::new(&system);
    make.args(["-m", "venv", "--clear"]).arg(&dir);
    println!("$ {}", display_command(&make));
    let status = make.status().context("could not start python3 -m venv")?;
    ensure!(
        status.success(),
        "`python3 -m venv` failed ({status}); on Debian it needs the package python3-venv"
    );
    let mut install = Command::new(&python);
    install
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
        ])
        .args(requirements);
    println!("$ {}", display_command(&install));
    let status = install.status().context("could not start pip")?;
    ensure!(status.success(), "pip install failed ({status})");
    std::fs::write(&marker, wanted).with_context(|| format!("writing {}", marker.display()))?;
    Ok(python)
}
