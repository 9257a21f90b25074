//! Makes a fresh machine ready, or says exactly what is missing:
//!
//! - the `thumbv7em-none-eabihf` target: listed in `rust-toolchain.toml`, so rustup adds
//!   it when it installs the toolchain from that file, but not to a toolchain that is
//!   already installed (checked with rustup 1.29): then `rustup target add`;
//! - `flip-link` (the ARM linker in `.cargo/config.toml`): `cargo install flip-link --locked`;
//! - `qemu-system-arm`: Debian's package, installed with apt-get when running as root,
//!   otherwise a message naming the package.

use std::env;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, Context as _, Result};

use crate::steps::{run_command, Context, TARGET};

/// Runs the three checks (all of them); each fixes what it can. The error lists every
/// tool still missing.
pub fn ensure_all(ctx: &Context) -> Result<()> {
    let problems: Vec<String> = [ensure_target(ctx), ensure_flip_link(ctx), ensure_qemu()]
        .into_iter()
        .filter_map(|r| r.err().map(|e| format!("{e:#}")))
        .collect();
    if !problems.is_empty() {
        bail!("{}", problems.join("\n    "));
    }
    Ok(())
}

/// The first `name` on `PATH`, if any.
pub fn on_path(name: &str) -> Option<PathBuf> {
    env::var_os("PATH")
        .iter()
        .flat_map(env::split_paths)
        .map(|dir| dir.join(name))
        .find(|candidate| is_executable(candidate))
}

/// Where `cargo install` puts programs.
fn cargo_bin() -> Option<PathBuf> {
    env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| env::var_os("HOME").map(|home| Path::new(&home).join(".cargo")))
        .map(|home| home.join("bin"))
}

fn is_executable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    path.metadata()
        .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

/// True when the toolchain in use has the standard library for [`TARGET`].
fn target_installed(ctx: &Context) -> Result<bool> {
    let output = Command::new("rustc")
        .args(["--print", "target-libdir", "--target", TARGET])
        .current_dir(&ctx.root)
        .stdin(Stdio::null())
        .output()
        .context("could not run `rustc --print target-libdir`")?;
    if !output.status.success() {
        return Ok(false);
    }
    let libdir = PathBuf::from(String::from_utf8_lossy(&output.stdout).trim());
    Ok(libdir.read_dir().is_ok_and(|mut entries| {
        entries.any(|e| e.is_ok_and(|e| e.file_name().to_string_lossy().starts_with("libcore-")))
    }))
}

fn ensure_target(ctx: &Context) -> Result<()> {
    if target_installed(ctx)? {
        println!("target {TARGET}: installed");
        return Ok(());
    }
    println!("target {TARGET}: missing, adding it with rustup");
    if on_path("rustup").is_none() {
        bail!(
            "the Rust target {TARGET} is missing and rustup is not available: install the \
             standard library for {TARGET} for this toolchain"
        );
    }
    run_command(
        Command::new("rustup")
            .args(["target", "add", TARGET])
            .current_dir(&ctx.root)
            .stdin(Stdio::null()),
    )?;
    if !target_installed(ctx)? {
        bail!("`rustup target add {TARGET}` ran but the target is still missing");
    }
    Ok(())
}

fn ensure_flip_link(ctx: &Context) -> Result<()> {
    if let Some(path) = on_path("flip-link") {
        println!("flip-link: {}", path.display());
        return Ok(());
    }
    let installed = cargo_bin().map(|bin| bin.join("flip-link"));
    if !installed.as_deref().is_some_and(is_executable) {
        println!("flip-link: missing, installing it (the ARM linker, see .cargo/config.toml)");
        run_command(&mut ctx.cargo(&["install", "flip-link", "--locked"]))?;
    }
    match (on_path("flip-link"), installed) {
        (Some(path), _) => {
            println!("flip-link: {}", path.display());
            Ok(())
        }
        (None, Some(path)) if is_executable(&path) => bail!(
            "flip-link is installed at {} but that directory is not on PATH, where rustc \
             looks for the linker: add it to PATH",
            path.display()
        ),
        (None, _) => bail!("`cargo install flip-link --locked` ran but flip-link is not found"),
    }
}

fn ensure_qemu() -> Result<()> {
    if let Some(path) = on_path("qemu-system-arm") {
        println!("qemu-system-arm: {}", path.display());
        return Ok(());
    }
    let apt = on_path("apt-get");
    if apt.is_none() || !running_as_root() {
        bail!(
            "qemu-system-arm is missing: install Debian's package `qemu-system-arm` \
             (as root: apt-get update && apt-get install -y qemu-system-arm), or your \
             distribution's QEMU ARM system emulator"
        );
    }
    println!("qemu-system-arm: missing, installing Debian's package qemu-system-arm");
    for args in [&["update"][..], &["install", "-y", "qemu-system-arm"][..]] {
        run_command(
            Command::new("apt-get")
                .args(args)
                .env("DEBIAN_FRONTEND", "noninteractive")
                .stdin(Stdio::null()),
        )?;
    }
    if on_path("qemu-system-arm").is_none() {
        bail!("apt-get installed qemu-system-arm but it is not on PATH");
    }
    Ok(())
}

/// True when the effective user id is 0 (read from `/proc/self/status`).
fn running_as_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|status| {
            let line = status.lines().find(|l| l.starts_with("Uid:"))?;
            // Uid: real effective saved filesystem
            line.split_whitespace().nth(2).map(|euid| euid == "0")
        })
        .unwrap_or(false)
}
