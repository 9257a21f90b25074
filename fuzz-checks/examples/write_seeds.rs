//! Writes the seeds of every fuzz target ([`fuzz_checks::seeds`]) into
//! `DIR/<target>/`: `cargo run -p fuzz-checks --example write_seeds -- DIR`.
//! `cargo xtask fuzz` runs it before fuzzing.

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let Some(dir) = std::env::args_os().nth(1).map(PathBuf::from) else {
        eprintln!("usage: write_seeds DIR");
        return ExitCode::FAILURE;
    };
    for target in fuzz_checks::TARGETS {
        let into = dir.join(target);
        let written = std::fs::create_dir_all(&into).and_then(|()| {
            let seeds = fuzz_checks::seeds::for_target(target);
            for (name, input) in &seeds {
                std::fs::write(into.join(name), input)?;
            }
            Ok(seeds.len())
        });
        match written {
            Ok(n) => println!("{target}: {n} seeds in {}", into.display()),
            Err(e) => {
                eprintln!("{}: {e}", into.display());
                return ExitCode::FAILURE;
            }
        }
    }
    ExitCode::SUCCESS
}
