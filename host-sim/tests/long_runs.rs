//! A long run's summary: one hourly figure per whole hour of the run.

use controller_core::law::LawKind;
use host_sim::{run_scenario_with, RunOptions};
use robot_files::scenario::{Scenario, BUILTIN};

/// Two hours of the paper's circle at a tenth of the usual rates (a 100 Hz control loop,
/// the plant at 1 kHz), so the test takes a second: the summary holds both hours. It held
/// one (and so printed none): the last hour's last sample comes one steering period
/// before the end, and the hour was closed only by a sample past it.
#[test]
fn a_two_hour_run_reports_both_hours() {
    let text = format!(
        "{}\n[robot]\ncontrol_rate_hz = 100\n",
        BUILTIN[0]
            .1
            .replace("plant_rate_hz = 10000", "plant_rate_hz = 1000")
    );
    let scenario = Scenario::from_toml(&text, "slow-circle")
        .unwrap()
        .with_duration_s(2.0 * 3600.0)
        .unwrap();
    let options = RunOptions::default();
    let r = run_scenario_with(&scenario, LawKind::Tracking, options).unwrap();
    let hours = &r.summary.hourly_rms_true_position_error_m;
    assert_eq!(hours.len(), 2, "{hours:?}");
    assert!(
        hours.iter().all(|h| h.is_finite() && *h >= 0.0),
        "{hours:?}"
    );
}
