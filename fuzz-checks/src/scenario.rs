//! Scenario files on any text ([`check`]).

use controller_core::reference::Reference;
use robot_files::scenario::{
    Scenario, ScenarioError, MAX_CONTROL_RATE_HZ, MAX_CONTROL_STEPS, MAX_DURATION_S,
};

use crate::numbers::assert_all_finite;

/// Loads `input` as a scenario file (input that is not UTF-8 is no text file: the
/// programs refuse it when they read the file); panics naming the broken property.
pub fn check(input: &[u8]) {
    let Ok(text) = std::str::from_utf8(input) else {
        return;
    };
    match Scenario::from_toml(text, "fuzz") {
        Ok(scenario) => assert_valid(&scenario),
        Err(e) => assert_names_what(&e),
    }
}

/// Every value finite and within its documented bound; the robot and supervisor
/// configurations valid by the core, the reference built by the core.
fn assert_valid(s: &Scenario) {
    assert_all_finite("a loaded scenario", s);
    assert!(
        s.duration_s > 0.0 && s.duration_s <= MAX_DURATION_S,
        "sim.duration_s {} out of (0, {MAX_DURATION_S}]",
        s.duration_s
    );
    let rate = s.robot.control_rate_hz;
    assert!(rate <= MAX_CONTROL_RATE_HZ, "control rate {rate} Hz");
    assert!(
        s.duration_s * f64::from(rate) <= MAX_CONTROL_STEPS,
        "{} s at {rate} Hz is over the step budget",
        s.duration_s
    );
    assert!(
        s.plant_rate_hz % rate == 0 && s.plant_rate_hz / rate >= 10,
        "plant rate {} Hz for a {rate} Hz loop",
        s.plant_rate_hz
    );
    let params = s
        .params()
        .unwrap_or_else(|e| panic!("a loaded scenario's robot is valid, yet: {e}"));
    if let Err(e) = s.supervisor.validate(&params) {
        panic!("a loaded scenario's supervisor settings are valid, yet: {e}");
    }
    assert!(s.reference_speed_m_s > 0.0, "reference speed");
    if let Err(e) = Reference::new(s.path.clone(), s.reference_speed_m_s, s.reference_mode) {
        panic!("a loaded scenario's reference builds, yet: {e}");
    }
    let path_m = s.path.length_m();
    assert!(path_m > 0.0 && path_m.is_finite(), "path length {path_m} m");
    let st = &s.start;
    for (key, v) in [
        ("start.x_m", st.x_m),
        ("start.y_m", st.y_m),
        ("start.theta_rad", st.theta_rad),
        ("start.v_m_s", st.v_m_s),
        ("start.omega_rad_s", st.omega_rad_s),
    ] {
        assert!((v as f32).is_finite(), "{key} = {v} is beyond f32");
    }
    for slip in s.plant.slip {
        assert!((0.0..1.0).contains(&slip), "slip ratio {slip}");
    }
    if let Err(e) = s.clone().with_duration_s(s.duration_s) {
        panic!("a loaded scenario's own duration is accepted again, yet: {e}");
    }
}

/// A refusal is a one-line message; an out-of-range value names its key and the problem.
fn assert_names_what(e: &ScenarioError) {
    let message = e.to_string();
    assert!(!message.trim().is_empty(), "an empty error: {e:?}");
    match e {
        ScenarioError::Invalid { key, problem } => {
            assert!(
                !key.is_empty() && !problem.is_empty(),
                "an error names the key and the problem: {e:?}"
            );
            assert!(message.starts_with(key.as_str()), "{message}");
        }
        ScenarioError::Section(section) => assert!(
            section.key.starts_with("robot.") || section.key.starts_with("supervisor."),
            "a section's error names a key of the section: {message}"
        ),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use robot_files::scenario::BUILTIN;

    #[test]
    fn every_built_in_scenario_passes() {
        for (_, text) in BUILTIN {
            check(text.as_bytes());
        }
    }

    #[test]
    fn a_refusal_names_its_key() {
        let text = BUILTIN[0].1.replace("radius_m = 1.25", "radius_m = -1.0");
        let e = Scenario::from_toml(&text, "x").unwrap_err();
        assert!(e.to_string().starts_with("path.radius_m"), "{e}");
        check(text.as_bytes());
    }
}
