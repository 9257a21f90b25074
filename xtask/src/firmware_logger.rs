//! A guard on the firmware's logger configuration: `defmt-rtt` must have both
//! `disable-blocking-mode` and `drop-on-contention`. With only the first, each log frame
//! is written inside a critical section (interrupts masked, the 1 kHz control interrupt
//! included); with only the second, a frame spins until the host reads once probe-rs has
//! put the channel in blocking mode, which freezes the control loop when the probe is
//! unplugged (firmware/README.md, "Reading the log"). Checked by a test, on what
//! `cargo metadata` reads from `firmware/Cargo.toml`.

use anyhow::{bail, Context as _, Result};
use serde_json::Value;

/// The features `defmt-rtt` must have in the firmware, both of them.
pub const REQUIRED: [&str; 2] = ["disable-blocking-mode", "drop-on-contention"];

/// Checks `cargo metadata` output (format 1): the package `firmware` depends on
/// `defmt-rtt` with every feature of [`REQUIRED`].
pub fn check(metadata: &Value) -> Result<()> {
    let packages = metadata["packages"]
        .as_array()
        .context("cargo metadata: no `packages` array")?;
    let firmware = packages
        .iter()
        .find(|p| p["name"] == "firmware")
        .context("cargo metadata: no package `firmware`")?;
    let dependencies = firmware["dependencies"]
        .as_array()
        .context("firmware: no `dependencies` array")?;
    let rtt = dependencies
        .iter()
        .find(|d| d["name"] == "defmt-rtt")
        .context("firmware does not depend on defmt-rtt")?;
    let features: Vec<&str> = rtt["features"]
        .as_array()
        .map(|f| f.iter().filter_map(Value::as_str).collect())
        .unwrap_or_default();
    let missing: Vec<&str> = REQUIRED
        .iter()
        .copied()
        .filter(|r| !features.contains(r))
        .collect();
    if !missing.is_empty() {
        bail!(
            "firmware/Cargo.toml: defmt-rtt lacks feature(s) {missing:?} (has {features:?}); \
             both {REQUIRED:?} are needed so that logging never masks interrupts or waits"
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::Command;

    fn metadata_with(features: &[&str]) -> Value {
        serde_json::json!({
            "packages": [
                { "name": "controller-core", "dependencies": [] },
                { "name": "firmware", "dependencies": [
                    { "name": "defmt", "features": [] },
                    { "name": "defmt-rtt", "features": features },
                ] },
            ]
        })
    }

    #[test]
    fn the_firmware_manifest_enables_both_features() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let output = Command::new(cargo)
            .args([
                "metadata",
                "--format-version",
                "1",
                "--no-deps",
                "--offline",
            ])
            .current_dir(root)
            .output()
            .expect("run cargo metadata");
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let metadata: Value = serde_json::from_slice(&output.stdout).expect("metadata JSON");
        check(&metadata).unwrap();
    }

    #[test]
    fn one_feature_alone_is_refused() {
        assert!(check(&metadata_with(&REQUIRED)).is_ok());
        for alone in REQUIRED {
            let err = check(&metadata_with(&[alone])).unwrap_err().to_string();
            let other = REQUIRED.iter().find(|r| **r != alone).unwrap();
            assert!(err.contains(other), "{err}");
        }
        assert!(check(&metadata_with(&[])).is_err());
        let no_rtt =
            serde_json::json!({ "packages": [{ "name": "firmware", "dependencies": [] }] });
        assert!(check(&no_rtt).is_err());
    }
}
