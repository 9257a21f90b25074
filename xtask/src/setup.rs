//! Makes a fresh machine ready, or says exactly what is missing:
//!
//! - the `thumbv7em-none-eabihf` target: listed in `rust-toolchain.toml`, so rustup adds
//!   it when it installs the toolchain from that file, but not to a toolchain that is
//!   already installed (checked with rustup 1.29): then `rustup target add`;
//! - `flip-link` (the ARM linker in `.cargo/config.toml`): `cargo install flip-link --locked`;
//! - `qemu-system-arm`: Debian's package, installed with apt-get when running as root,
//!   otherwise a message naming the package;
//! - for the protocol client's step only ([`ensure_python3`]): `python3`, 3.8 or later,
//!   the same way (Debian's `python3`);
//! - for the Miri step only ([`ensure_miri`]): the nightly toolchain with its `miri` and
//!   `rust-src` components, installed with rustup, and Miri's own build of the standard
//!   library (`cargo +nightly miri setup`);
//! - for the fuzz targets only ([`ensure_fuzzing`]): the nightly toolchain and
//!   `cargo-fuzz` (`cargo install cargo-fuzz --locked`).

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
    ensure_cargo_program(
        ctx,
        "flip-link",
        "the ARM linker, see .cargo/config.toml",
        "rustc looks for the linker",
    )
}

/// Makes the program `name` (a crate of the same name, installed with `cargo install
/// NAME --locked`) available on `PATH`; `why` says what it is for, `who` who looks for it
/// there (e.g. "rustc looks for the linker").
fn ensure_cargo_program(ctx: &Context, name: &str, why: &str, who: &str) -> Result<()> {
    if let Some(path) = on_path(name) {
        println!("{name}: {}", path.display());
        return Ok(());
    }
    let installed = cargo_bin().map(|bin| bin.join(name));
    if !installed.as_deref().is_some_and(is_executable) {
        println!("{name}: missing, installing it ({why})");
        run_command(&mut ctx.cargo(&["install", name, "--locked"]))?;
    }
    match (on_path(name), installed) {
        (Some(path), _) => {
            println!("{name}: {}", path.display());
            Ok(())
        }
        (None, Some(path)) if is_executable(&path) => bail!(
            "{name} is installed at {} but that directory is not on PATH, where {who}: \
             add it to PATH",
            path.display()
        ),
        (None, _) => bail!("`cargo install {name} --locked` ran but {name} is not found"),
    }
}

fn ensure_qemu() -> Result<()> {
    ensure_program(
        "qemu-system-arm",
        "qemu-system-arm",
        "or your distribution's QEMU ARM system emulator",
    )
    .map(drop)
}

/// `python3` (3.8 or later), for the protocol client's step: Debian's package `python3`
/// when missing and running as root; the client needs nothing beyond
/// Python's standard library, so no environment is set up for it.
pub fn ensure_python3() -> Result<PathBuf> {
    let python = ensure_program("python3", "python3", "or Python 3.8 or later")?;
    let output = Command::new(&python)
        .args([
            "-c",
            "import sys; print(sys.version_info[0], sys.version_info[1])",
        ])
        .output()
        .with_context(|| format!("could not run {}", python.display()))?;
    let version = String::from_utf8_lossy(&output.stdout).trim().to_string();
    let parsed: Vec<u32> = version
        .split_whitespace()
        .filter_map(|n| n.parse().ok())
        .collect();
    match parsed.as_slice() {
        [major, minor] if (*major, *minor) >= (3, 8) => Ok(python),
        _ => bail!(
            "{} is Python `{version}`; the protocol client needs Python 3.8 or later",
            python.display()
        ),
    }
}

/// The program `name` on `PATH`, installing Debian's `package` with apt-get when it is
/// missing and this runs as root; otherwise an error naming the package and `otherwise`.
pub fn ensure_program(name: &str, package: &str, otherwise: &str) -> Result<PathBuf> {
    if let Some(path) = on_path(name) {
        println!("{name}: {}", path.display());
        return Ok(path);
    }
    let apt = on_path("apt-get");
    if apt.is_none() || !running_as_root() {
        bail!(
            "{name} is missing: install Debian's package `{package}` (as root: apt-get \
             update && apt-get install -y {package}), {otherwise}"
        );
    }
    println!("{name}: missing, installing Debian's package {package}");
    for args in [&["update"][..], &["install", "-y", package][..]] {
        run_command(
            Command::new("apt-get")
                .args(args)
                .env("DEBIAN_FRONTEND", "noninteractive")
                .stdin(Stdio::null()),
        )?;
    }
    on_path(name).with_context(|| format!("apt-get installed {package} but {name} is not on PATH"))
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

/// The toolchain Miri and the fuzz targets run on (Miri ships with nightly only, and
/// libFuzzer's instrumentation needs nightly's `-Z` flags).
pub const NIGHTLY: &str = "nightly";
/// The nightly components Miri needs: itself, and the standard library's source, which
/// `cargo miri setup` builds Miri's standard library from.
const MIRI_COMPONENTS: [&str; 2] = ["miri", "rust-src"];

/// `cargo <args>` on the [`NIGHTLY`] toolchain, through rustup, in the workspace root (the
/// variables that name another toolchain's tools are removed, so nothing of the stable
/// toolchain that runs xtask leaks in).
pub fn nightly_cargo(ctx: &Context, args: &[&str]) -> Command {
    let mut cmd = Command::new("rustup");
    cmd.args(["run", NIGHTLY, "cargo"])
        .args(args)
        .current_dir(&ctx.root)
        .stdin(Stdio::null());
    for var in ["RUSTUP_TOOLCHAIN", "RUSTC", "RUSTDOC", "CARGO"] {
        cmd.env_remove(var);
    }
    cmd
}

/// The Miri components the nightly toolchain lacks; None when nightly itself is not
/// installed.
fn missing_miri_components(ctx: &Context) -> Result<Option<Vec<&'static str>>> {
    let output = Command::new("rustup")
        .args(["component", "list", "--installed", "--toolchain", NIGHTLY])
        .current_dir(&ctx.root)
        .stdin(Stdio::null())
        .output()
        .context("could not run `rustup component list`")?;
    if !output.status.success() {
        return Ok(None);
    }
    let listed = String::from_utf8_lossy(&output.stdout);
    // Listed as `miri-x86_64-unknown-linux-gnu`, `rust-src`.
    let has = |component: &str| {
        listed.lines().any(|line| {
            let line = line.trim();
            line == component || line.starts_with(&format!("{component}-"))
        })
    };
    Ok(Some(
        MIRI_COMPONENTS.into_iter().filter(|c| !has(c)).collect(),
    ))
}

/// Makes `cargo +nightly miri` ready: installs the nightly toolchain with Miri's
/// components when it is missing, adds the components when only they are, then runs
/// `cargo miri setup` (which builds Miri's standard library once, into its cache, and is
/// quick after that). Never updates a nightly already installed. The error names what is
/// missing and the command that would install it.
pub fn ensure_miri(ctx: &Context) -> Result<()> {
    // `--allow-downgrade`: the newest nightly that has every component, should the very
    // latest lack Miri. `--no-self-update`: rustup itself stays as it is (a fresh rustup
    // home would otherwise let the install replace the rustup binary).
    const INSTALL_ARGS: [&str; 11] = [
        "toolchain",
        "install",
        NIGHTLY,
        "--allow-downgrade",
        "--no-self-update",
        "--component",
        "miri",
        "--component",
        "rust-src",
        "--profile",
        "minimal",
    ];
    let install = format!("rustup {}", INSTALL_ARGS.join(" "));
    if on_path("rustup").is_none() {
        bail!(
            "Miri needs the nightly toolchain with its miri component, and rustup is not \
             available to install it: install rustup, then `{install}`"
        );
    }
    match missing_miri_components(ctx)? {
        None => {
            println!("toolchain {NIGHTLY}: missing, installing it with Miri");
            run_command(
                Command::new("rustup")
                    .args(INSTALL_ARGS)
                    .current_dir(&ctx.root)
                    .stdin(Stdio::null()),
            )
            .with_context(|| {
                format!(
                    "the {NIGHTLY} toolchain with its miri component is missing and \
                     could not be installed (no network?)"
                )
            })?;
        }
        Some(missing) if !missing.is_empty() => {
            println!(
                "toolchain {NIGHTLY}: missing the component(s) {}, adding them",
                missing.join(", ")
            );
            run_command(
                Command::new("rustup")
                    .args(["component", "add", "--toolchain", NIGHTLY])
                    .args(&missing)
                    .current_dir(&ctx.root)
                    .stdin(Stdio::null()),
            )
            .with_context(|| {
                format!(
                    "the {NIGHTLY} toolchain lacks {} and rustup could not add it \
                     (no network?)",
                    missing.join(" and ")
                )
            })?;
        }
        Some(_) => {}
    }
    match missing_miri_components(ctx)? {
        Some(missing) if missing.is_empty() => {
            println!("toolchain {NIGHTLY}: with {}", MIRI_COMPONENTS.join(", "))
        }
        Some(missing) => bail!(
            "rustup ran but the {NIGHTLY} toolchain still lacks {}",
            missing.join(" and ")
        ),
        None => bail!("rustup ran but the {NIGHTLY} toolchain is still not installed"),
    }
    run_command(&mut nightly_cargo(ctx, &["miri", "setup"])).context(
        "Miri's standard library could not be built (`cargo +nightly miri setup`, from the \
         rust-src component and the crates it needs; no network?)",
    )
}

/// Makes `cargo +nightly fuzz` ready: the [`NIGHTLY`] toolchain (installed with rustup,
/// minimal profile, when missing; never updated) and `cargo-fuzz` (`cargo install
/// cargo-fuzz --locked` when missing). The error names what is missing and the command
/// that would install it.
pub fn ensure_fuzzing(ctx: &Context) -> Result<()> {
    const INSTALL_ARGS: [&str; 6] = [
        "toolchain",
        "install",
        NIGHTLY,
        "--no-self-update",
        "--profile",
        "minimal",
    ];
    let nightly_runs = || {
        Command::new("rustup")
            .args(["run", NIGHTLY, "rustc", "--version"])
            .current_dir(&ctx.root)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|status| status.success())
    };
    let install = format!("rustup {}", INSTALL_ARGS.join(" "));
    if on_path("rustup").is_none() {
        bail!(
            "the fuzz targets need the {NIGHTLY} toolchain, and rustup is not available to \
             install it: install rustup, then `{install}`"
        );
    }
    if nightly_runs() {
        println!("toolchain {NIGHTLY}: installed");
    } else {
        println!("toolchain {NIGHTLY}: missing, installing it");
        run_command(
            Command::new("rustup")
                .args(INSTALL_ARGS)
                .current_dir(&ctx.root)
                .stdin(Stdio::null()),
        )
        .with_context(|| {
            format!("the {NIGHTLY} toolchain is missing and `{install}` failed (no network?)")
        })?;
        if !nightly_runs() {
            bail!("rustup ran but the {NIGHTLY} toolchain is still not installed");
        }
    }
    ensure_cargo_program(
        ctx,
        "cargo-fuzz",
        "cargo fuzz, libFuzzer's driver",
        "cargo looks for its subcommands",
    )
}
