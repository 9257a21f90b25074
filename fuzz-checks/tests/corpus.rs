//! Replays the committed corpus of every fuzz target (`fuzz/corpus/<target>/`) and the
//! seeds built from the project through the same check the fuzz target runs: what the
//! fuzzer once found stays checked on stable, in CI.

use std::fs;
use std::path::PathBuf;

use fuzz_checks::{check, seeds, TARGETS};

/// `fuzz/corpus/<target>/`.
fn corpus_dir(target: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz/corpus")
        .join(target)
}

/// Runs `target`'s check on every file of its corpus and on its seeds; the number of
/// corpus files.
fn replay(target: &str) -> usize {
    let dir = corpus_dir(target);
    let entries = fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let mut files = 0;
    for entry in entries {
        let path = entry.expect("a readable directory entry").path();
        let input = fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        // The check's panic names the property; the file is named here.
        eprintln!("{target}: {}", path.display());
        assert!(check(target, &input));
        files += 1;
    }
    for (_, input) in seeds::for_target(target) {
        assert!(check(target, &input));
    }
    files
}

#[test]
fn link_frames_corpus() {
    assert!(replay("link_frames") > 0);
}

#[test]
fn link_messages_corpus() {
    assert!(replay("link_messages") > 0);
}

#[test]
fn param_record_corpus() {
    assert!(replay("param_record") > 0);
}

#[test]
fn scenario_corpus() {
    assert!(replay("scenario") > 0);
}

#[test]
fn robot_file_corpus() {
    assert!(replay("robot_file") > 0);
}

/// Every target has its test above, and its corpus directory.
#[test]
fn every_target_is_replayed() {
    let source = include_str!("corpus.rs");
    for target in TARGETS {
        assert!(
            source.contains(&format!("fn {target}_corpus()")),
            "no replay test for {target}"
        );
        assert!(corpus_dir(target).is_dir(), "no corpus for {target}");
    }
}

/// The fuzz crate declares exactly these targets, each a binary of the same name around
/// the check of that name.
#[test]
fn the_fuzz_crate_has_every_target() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fuzz");
    let manifest = fs::read_to_string(dir.join("Cargo.toml")).expect("fuzz/Cargo.toml");
    let mut declared: Vec<&str> = manifest
        .lines()
        .filter_map(|line| line.strip_prefix("name = \""))
        .filter_map(|rest| rest.strip_suffix('"'))
        .filter(|name| *name != "fuzz")
        .collect();
    declared.sort_unstable();
    let mut targets = TARGETS.to_vec();
    targets.sort_unstable();
    assert_eq!(declared, targets);
    for target in TARGETS {
        let source = fs::read_to_string(dir.join("fuzz_targets").join(format!("{target}.rs")))
            .unwrap_or_else(|e| panic!("fuzz/fuzz_targets/{target}.rs: {e}"));
        assert!(source.contains("fuzz_checks::"), "{target} runs no check");
    }
}
