//! Puts the chip's `memory.x` where the linker finds it, adds the linker scripts of
//! `cortex-m-rt` (`link.x`) and `defmt` (`defmt.x`) for this crate's binary and its
//! first-flash programs (`examples/`) only, and
//! makes `info` this crate's default defmt log level.
//!
//! It also sets `FIRMWARE_GIT_HASH` (the commit the firmware is built from, 12 hex
//! digits, `-dirty` when the work tree differs from it; `unknown` outside git) for the
//! link's `Info`.
//!
//! The scripts are passed here rather than in `.cargo/config.toml` because another
//! `no_std` program in the workspace (in `tests/`) is built for the same target without
//! defmt.
//!
//! `link.x` says `INCLUDE memory.x`, and the linker looks in its working directory (the
//! workspace root, where cargo runs rustc) before the search path: a `memory.x` there
//! would silently replace the chip's map written here (it did: the STM32F401 build used
//! the F411's 128 KiB of RAM). So the F411 map lives in `memory/stm32f411.x`, and this
//! script refuses to build while a `memory.x` sits in the workspace root.

use std::env;
use std::fs;
use std::path::PathBuf;

/// `memory.x` of the port examples (the F411's is `memory/stm32f411.x`).
const MEMORY_F401: &str = "/* STM32F401CC: 256 KiB flash, 64 KiB SRAM. */
MEMORY
{
  FLASH : ORIGIN = 0x08000000, LENGTH = 256K
  RAM   : ORIGIN = 0x20000000, LENGTH = 64K
}
";
const MEMORY_F446: &str = "/* STM32F446RE: 512 KiB flash, 128 KiB SRAM (SRAM1 + SRAM2). FLASH
   stops at sector 6, which with sector 7 holds the parameter records (the F411's
   layout). */
MEMORY
{
  FLASH : ORIGIN = 0x08000000, LENGTH = 256K
  RAM   : ORIGIN = 0x20000000, LENGTH = 128K
}
";

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let f411 = manifest.join("memory").join("stm32f411.x");
    let shadowing = manifest.join("..").join("memory.x");
    println!("cargo:rerun-if-changed={}", shadowing.display());
    assert!(
        !shadowing.exists(),
        "{} would replace the chip's memory map at link time; remove it",
        shadowing.display()
    );

    let memory = if env::var_os("CARGO_FEATURE_STM32F401").is_some() {
        MEMORY_F401.to_owned()
    } else if env::var_os("CARGO_FEATURE_STM32F446").is_some() {
        MEMORY_F446.to_owned()
    } else {
        println!("cargo:rerun-if-changed={}", f411.display());
        fs::read_to_string(&f411).expect("read memory/stm32f411.x")
    };
    fs::write(out.join("memory.x"), memory).expect("write memory.x to OUT_DIR");

    // Telemetry is logged at `info`; defmt's own default is `error` only. Default this
    // crate (only) to `info`; an explicit DEFMT_LOG wins.
    println!("cargo:rerun-if-env-changed=DEFMT_LOG");
    if env::var_os("DEFMT_LOG").is_none() {
        println!("cargo:rustc-env=DEFMT_LOG=info");
    }

    git_hash(&manifest);

    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=build.rs");
    // Only when building for the MCU: a host `cargo check` of the crate must not ask the
    // host linker for these scripts.
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        for kind in ["bins", "examples"] {
            println!("cargo:rustc-link-arg-{kind}=--nmagic");
            println!("cargo:rustc-link-arg-{kind}=-Tlink.x");
            println!("cargo:rustc-link-arg-{kind}=-Tdefmt.x");
        }
    }
}

/// Sets `FIRMWARE_GIT_HASH` and asks cargo to rerun when HEAD, the branch it points to
/// or the index moves.
fn git_hash(manifest: &std::path::Path) {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .current_dir(manifest)
            .output()
            .ok()
            .filter(|out| out.status.success())
            .map(|out| String::from_utf8_lossy(&out.stdout).trim().to_owned())
    };
    let hash = match git(&["rev-parse", "--short=12", "HEAD"]) {
        Some(hash) => {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|status| !status.is_empty());
            for watched in ["HEAD", "index"] {
                if let Some(path) = git(&["rev-parse", "--git-path", watched]) {
                    println!("cargo:rerun-if-changed={}", manifest.join(path).display());
                }
            }
            if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
                if let Some(path) = git(&["rev-parse", "--git-path", &branch]) {
                    println!("cargo:rerun-if-changed={}", manifest.join(path).display());
                }
            }
            if dirty {
                format!("{hash}-dirty")
            } else {
                hash
            }
        }
        None => "unknown".to_owned(),
    };
    println!("cargo:rustc-env=FIRMWARE_GIT_HASH={hash}");
}
