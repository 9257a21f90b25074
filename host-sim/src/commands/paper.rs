//! `host-sim paper`: the paper's experiments (section 4, its circle and its line) with
//! every law — Figs. 5–7, `trace.csv` and `summary.json` of each run, an overlay per
//! experiment, the comparison table and what the runs show.

use std::fmt;
use std::path::PathBuf;

use anyhow::Result;
use controller_core::law::LawKind;
use robot_files::output::settle_text;

use super::compare::Comparison;
use super::{load, Report};
use crate::output;

/// The built-in scenarios of the paper's experiments, in the order they run.
pub const EXPERIMENTS: [&str; 2] = ["paper-circle", "paper-line"];

/// One experiment: every law's run and the folder its files are in.
#[derive(Clone, Debug)]
pub struct Experiment {
    /// Every law's run.
    pub comparison: Comparison,
    /// `<root>/<scenario>`: one folder per law and `compare.svg`.
    pub dir: PathBuf,
}

impl fmt::Display for Experiment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.comparison)?;
        writeln!(
            f,
            "wrote {}/{{paper,tracking,kanayama}}/ (Figs. 5–7, summary.json, trace.csv) and compare.svg\n",
            self.dir.display()
        )?;
        let scenario = &self.comparison.scenario;
        let gamma = f64::from(scenario.robot.law.paper.gamma);
        let lag = f64::from(scenario.reference_speed_m_s) / gamma;
        for (law, r) in &self.comparison.results {
            let s = r.summary.headline_error();
            match law {
                LawKind::Paper => writeln!(
                    f,
                    "  paper law (33)–(34): trails the moving reference by {:.4} m; a regulation \
law settles where v = v_r, at r_e ≈ v_r/γ = {lag:.4} m (docs/paper-errata.md, item 3)",
                    s.final_position_error_m
                )?,
                LawKind::Tracking => writeln!(
                    f,
                    "  tracking law: {} to |e| < 1 cm and |θ_e| < 1° (the paper reports 5–6 s), \
final error {:.4} m",
                    settle_text(s.settle_time_s),
                    s.final_position_error_m
                )?,
                LawKind::Kanayama => {}
            }
        }
        writeln!(f)
    }
}

/// Both experiments and the folder they are under.
#[derive(Clone, Debug)]
pub struct PaperReport {
    /// In [`EXPERIMENTS`] order.
    pub experiments: Vec<Experiment>,
    /// The output folder.
    pub root: PathBuf,
}

impl fmt::Display for PaperReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for experiment in &self.experiments {
            write!(f, "{experiment}")?;
        }
        writeln!(f, "figures and summaries: {}", self.root.display())
    }
}

impl Report for PaperReport {}

/// Runs both experiments with every law and writes their files under `out` (`None`:
/// `host-sim-out/paper`).
pub fn run(out: Option<PathBuf>) -> Result<PaperReport> {
    let root = out.unwrap_or_else(|| PathBuf::from("host-sim-out").join("paper"));
    let mut experiments = Vec::new();
    for name in EXPERIMENTS {
        let scenario = load(name)?;
        let comparison = Comparison::run(&scenario)?;
        let dir = root.join(name);
        for (law, result) in &comparison.results {
            output::write_run(&dir.join(law.name()), &scenario, result)?;
        }
        comparison.write_overlay(&dir)?;
        experiments.push(Experiment { comparison, dir });
    }
    Ok(PaperReport { experiments, root })
}
