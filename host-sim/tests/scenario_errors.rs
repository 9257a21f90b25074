//! A bad scenario file gets an error that names the key and the problem, and never
//! panics.

use host_sim::{run_scenario_with, RunOptions};
use robot_files::plant::DriverKind;
use robot_files::scenario::{Scenario, BUILTIN};

/// The paper-circle scenario with `table` appended (TOML tables can be re-opened only
/// once, so the tests use keys the built-in does not set).
fn with(extra: &str) -> Result<Scenario, String> {
    let base = BUILTIN[0].1;
    Scenario::from_toml(&format!("{base}\n{extra}\n"), "test.toml").map_err(|e| e.to_string())
}

fn error(extra: &str) -> String {
    match with(extra) {
        Ok(_) => panic!("accepted: {extra}"),
        Err(e) => e,
    }
}

#[test]
fn robot_values_are_checked_with_their_key_and_value() {
    assert_eq!(
        error("[robot]\nwheel_radius_m = -0.03"),
        "robot.wheel_radius_m must be > 0, got -0.03"
    );
    assert_eq!(
        error("[robot]\ntrack_width_m = 0.0"),
        "robot.track_width_m must be > 0, got 0"
    );
    assert_eq!(
        error("[robot]\nspeed_window_steps = 65"),
        "robot.speed_window_steps must be in 1..=64, got 65"
    );
    assert_eq!(
        error("[robot.limits]\nmax_rim_speed_m_s = -1.0"),
        "robot.limits.max_rim_speed_m_s must be > 0, got -1"
    );
    assert_eq!(
        error("[robot.law.paper]\ngamma = 0.0"),
        "robot.law.paper.gamma must be > 0, got 0"
    );
    assert_eq!(
        error("[robot.wheels]\nti_s = -0.1"),
        "robot.wheels.ti_s must be ≥ 0, got -0.1"
    );
    assert_eq!(
        error("[robot.right_wheel]\nkv_v_per_rad_s = 0.0"),
        "robot.right_wheel.kv_v_per_rad_s must be > 0, got 0"
    );
    assert_eq!(
        error("[robot.motor]\nmax_current_a = -1.0"),
        "robot.motor.max_current_a must be > 0, got -1"
    );
    // A control rate the encoder cannot resolve (one tick per window is 60 % of the top
    // speed at 100 kHz) is refused with the reason.
    assert!(error("[robot]\ncontrol_rate_hz = 100000")
        .starts_with("robot.speed_window_steps is too short"));
    assert_eq!(
        error("[robot]\nencoder_lines_per_motor_rev = 0"),
        "robot.encoder_lines_per_motor_rev must be > 0, got 0"
    );
}

#[test]
fn plant_and_sim_values_are_checked_with_their_key_and_value() {
    assert_eq!(
        error("[plant.motor]\nresistance_ohm = 0.0"),
        "plant.motor.resistance_ohm must be > 0, got 0"
    );
    assert_eq!(
        error("[plant.slip]\nleft = 1.5"),
        "plant.slip.left must be in [0, 1), got 1.5"
    );
    assert_eq!(
        error("[plant.motor_mismatch]\ntorque_constant_left_right_pct = 60.0"),
        "plant.motor_mismatch.torque_constant_left_right_pct must be in [-50, 50] %, got 60"
    );
    assert_eq!(
        with("[plant.motor_mismatch]\ncoulomb_friction_left_right_pct = -8.0")
            .unwrap()
            .plant
            .motor_mismatch
            .coulomb_friction_left_right_pct,
        -8.0
    );
    assert_eq!(
        error("[plant]\nsupply_v = nan"),
        "plant.supply_v must be > 0, got NaN"
    );
    assert_eq!(
        error("[plant.mismatch]\ntrack_width_pct = 80.0"),
        "plant.mismatch.track_width_pct must be in [-50, 50] %, got 80"
    );
    assert_eq!(
        error("[sweep]\nslip_max = 0.9"),
        "sweep.slip_max must be in [0, 0.5], got 0.9"
    );
    assert_eq!(
        error("[plant]\nencoder_noise_ticks_rms = 0.6"),
        "plant.encoder_noise_ticks_rms must be in [0, 0.5] (each edge within a tick of its \
         place), got 0.6"
    );
    assert_eq!(
        error("[sweep]\nencoder_noise_ticks_rms_max = 0.6"),
        "sweep.encoder_noise_ticks_rms_max must be in [0, 0.5], got 0.6"
    );
    // [sim] is set by the built-in, so use a scenario of our own for it.
    let text = BUILTIN[0]
        .1
        .replace("plant_rate_hz = 10000", "plant_rate_hz = 5000");
    let e = Scenario::from_toml(&text, "t").unwrap_err().to_string();
    assert!(
        e.starts_with("sim.plant_rate_hz must be a multiple of robot.control_rate_hz (1000)"),
        "{e}"
    );
    assert!(e.ends_with("got 5000"), "{e}");
}

#[test]
fn path_reference_and_start_errors_name_the_key() {
    let circle = BUILTIN[0].1;
    let e = Scenario::from_toml(&circle.replace("radius_m = 1.25", "radius_m = -1.25"), "t");
    assert_eq!(
        e.unwrap_err().to_string(),
        "path.radius_m must be > 0, got -1.25"
    );
    let e = Scenario::from_toml(&circle.replace("speed_m_s = 0.25", "speed_m_s = 0.0"), "t");
    assert_eq!(
        e.unwrap_err().to_string(),
        "reference.speed_m_s must be > 0, got 0"
    );
    let e = Scenario::from_toml(&circle.replace("kind = \"circle\"", "kind = \"line\""), "t");
    let e = e.unwrap_err().to_string();
    assert!(
        e.starts_with("path.center_m is not used by kind = \"line\""),
        "{e}"
    );
    let e = Scenario::from_toml(&circle.replace("x_m = -1.0", "x_m = inf"), "t");
    assert_eq!(
        e.unwrap_err().to_string(),
        "start.x_m must be finite, got inf"
    );
    let e = Scenario::from_toml(&circle.replace("v_m_s = 0.4", "v_m_s = 40.0"), "t");
    assert!(e
        .unwrap_err()
        .to_string()
        .starts_with("start.v_m_s with start.omega_rad_s"));
    let e = Scenario::from_toml(
        &circle.replace("start_offset_m = 0.0", "lookahead_m = 0.1"),
        "t",
    );
    assert_eq!(
        e.unwrap_err().to_string(),
        "reference.lookahead_m is only used with mode = \"path-following\""
    );
}

#[test]
fn syntax_unknown_keys_and_wrong_types_name_the_key() {
    // A typo is an error, not a silently ignored key.
    let e = error("[robot]\nwheel_radius = 0.03");
    assert!(e.contains("unknown field `wheel_radius`"), "{e}");
    assert!(e.starts_with("test.toml:"), "{e}");
    let e = error("[robot]\nwheel_radius_m = \"big\"");
    assert!(
        e.contains("wheel_radius_m") && e.contains("invalid type"),
        "{e}"
    );
    let e = Scenario::from_toml("name = \"x\"\n[path]\nkind = \"circle\"\n", "t").unwrap_err();
    assert!(e.to_string().contains("missing field `reference`"), "{e}");
    let e = Scenario::from_toml("this is = not toml", "t").unwrap_err();
    assert!(e.to_string().starts_with("t:"), "{e}");
    let e = Scenario::load("no-such-scenario").unwrap_err().to_string();
    assert!(
        e.contains("no-such-scenario") && e.contains("paper-circle"),
        "{e}"
    );
}

#[test]
fn far_positions_and_long_lengths_are_refused_on_the_key_written() {
    let circle = BUILTIN[0].1;
    let line = BUILTIN[1].1;
    let refused = |text: &str, from: &str, to: &str| replaced_error(text, from, to);
    // Each was refused as `supervisor.geofence_radius_m must be > 0`: the geofence derived
    // from the path and the start overflowed f32.
    assert_eq!(
        refused(circle, "radius_m = 1.25", "radius_m = 1e30"),
        "path.radius_m must be ≤ 1000 m, got 1e30"
    );
    assert_eq!(
        refused(circle, "x_m = -1.0", "x_m = 1e30"),
        "start.x_m must be within ±1000 m of the origin, got 1e30"
    );
    assert_eq!(
        refused(circle, "y_m = -1.2", "y_m = -1e30"),
        "start.y_m must be within ±1000 m of the origin, got -1e30"
    );
    assert_eq!(
        refused(circle, "center_m = [0.0, 0.0]", "center_m = [0.0, 2e3]"),
        "path.center_m[1] must be within ±1000 m of the origin, got 2000"
    );
    assert_eq!(
        refused(line, "length_m = 10.0", "length_m = 1e30"),
        "path.length_m must be ≤ 1000 m, got 1e30"
    );
    // At the bound, everything the supervisor derives is finite and the run starts.
    let mut far = replaced(circle, "radius_m = 1.25", "radius_m = 1000.0").unwrap();
    let geofence = far
        .supervisor
        .geofence_radius_m
        .expect("derived from the path");
    assert!(geofence.is_finite() && geofence > 1000.0, "{geofence}");
    far.duration_s = 0.01;
    let options = RunOptions::default();
    run_scenario_with(&far, controller_core::law::LawKind::Tracking, options).unwrap();
}

/// The paper's start in motion on a floor where the wheels slip 99 %: the run reported
/// peaks of 1 300 rad/s and 42 A, the plant having been started with its wheels 36 × above
/// the motor's no-load speed (the body's 0.4 m/s needs the wheels 100 × faster than they
/// roll). It is refused, with the keys and the figures; a reachable slip runs, and no
/// wheel in it turns faster than the no-load speed.
#[test]
fn a_start_in_motion_beyond_the_motors_is_refused() {
    let slip = |s: f64| with(&format!("[plant.slip]\nleft = {s}\nright = {s}")).unwrap();
    let e = run_scenario_with(
        &slip(0.99),
        controller_core::law::LawKind::Tracking,
        RunOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        "start.v_m_s = 0.4 m/s with start.omega_rad_s = 0.3 rad/s cannot be the robot's \
         motion: the right wheel would turn at 1300.0 rad/s (slip 0.99), beyond its motor's \
         no-load speed of 35.7 rad/s on 6 V"
    );
    let mut reachable = slip(0.5);
    reachable.duration_s = 2.0;
    let r = run_scenario_with(
        &reachable,
        controller_core::law::LawKind::Tracking,
        RunOptions::default(),
    )
    .unwrap();
    let peak = r.summary.max_wheel_speed_rad_s;
    assert!(peak > 25.0 && peak <= 35.72, "{peak} rad/s");
    assert!(r.max_current_a < 1.4, "{} A", r.max_current_a);
}

#[test]
fn deep_nesting_names_the_line_and_what_is_too_deep() {
    let base = BUILTIN[0].1;
    // `with` appends after one blank line: the extra text starts two lines past the base.
    let first_extra_line = base.lines().count() + 2;
    let deep_key = vec!["a"; 200].join(".");
    let e = error(&format!("{deep_key} = 1"));
    assert_eq!(
        e,
        format!(
            "test.toml: line {first_extra_line}: the key `{}…` has 200 parts; a key may \
             have at most 16",
            &deep_key[..40]
        )
    );
    // The same in a table header, one line further down.
    let e = error(&format!("x = 1\n[{deep_key}]\nb = 1"));
    assert!(
        e.starts_with(&format!(
            "test.toml: line {}: the key `a.a.",
            first_extra_line + 1
        )),
        "{e}"
    );
    // Arrays nested past the limit, under a real key.
    let e = error(&format!(
        "[robot]\nwheel_radius_m = {}{}",
        "[".repeat(200),
        "]".repeat(200)
    ));
    assert_eq!(
        e,
        format!(
            "test.toml: line {}: arrays and inline tables nest more than 16 deep; a value \
             may nest at most 16",
            first_extra_line + 1
        )
    );
    // A robot file (the station's `params set`) is read the same way.
    let e = robot_files::robot_file::RobotFile::from_toml(&format!("\n{deep_key} = 1\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 2: the key `a.a."), "{e}");
}

/// Every float in every built-in scenario replaced, one at a time, by values that are out
/// of range, absurd or not numbers: loading returns `Ok` or `Err`, never panics, and a
/// scenario that loads also runs (briefly) without panicking.
#[test]
fn no_bad_value_panics() {
    let bad = [
        "-1.0", "0.0", "1e40", "-1e-40", "nan", "inf", "-inf", "3.0e9",
    ];
    let mut loaded = 0;
    let mut rejected = 0;
    for (name, text) in BUILTIN {
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let Some((key, value)) = line.split_once('=') else {
                continue;
            };
            let value = value.split('#').next().unwrap_or("").trim();
            if key.trim_start().starts_with('#') || !value.contains('.') || value.contains('"') {
                continue;
            }
            for replacement in bad {
                let mut mutated = lines.clone();
                let new_line = format!("{} = {replacement}", key.trim_end());
                mutated[i] = &new_line;
                match Scenario::from_toml(&mutated.join("\n"), name) {
                    Err(e) => {
                        // The message names the key, or (for arrays) the path table.
                        let key = key.trim();
                        let text = e.to_string();
                        assert!(
                            text.contains(key) || text.starts_with("path"),
                            "{name}: {key} = {replacement}: {text}"
                        );
                        rejected += 1;
                    }
                    Ok(mut s) => {
                        s.duration_s = 0.05;
                        let r = run_scenario_with(
                            &s,
                            controller_core::law::LawKind::Tracking,
                            RunOptions::at_steering_rate(&s),
                        );
                        assert!(r.is_ok(), "{name}: {key} = {replacement}");
                        loaded += 1;
                    }
                }
            }
        }
    }
    assert!(
        rejected > 50 && loaded > 10,
        "rejected {rejected}, loaded {loaded}"
    );
}

/// Integer keys at zero, at the edge and absurdly large: loading returns `Ok` or an error
/// naming the key, never panics, never asks for memory it cannot have, and a scenario that
/// loads also runs (briefly). The built-in sets `sim.plant_rate_hz = 10000`, so the control
/// rate is varied together with it.
#[test]
fn no_bad_integer_panics_or_hangs() {
    let base = BUILTIN[0].1;
    let cases: &[(&str, &str)] = &[
        ("[robot]\ncontrol_rate_hz = 0", "robot.control_rate_hz"),
        (
            "[robot]\ncontrol_rate_hz = 100000000",
            "robot.control_rate_hz",
        ),
        (
            "[robot]\ncontrol_rate_hz = 4294967295",
            "robot.control_rate_hz",
        ),
        ("[robot]\nsteering_divider = 0", "robot.steering_divider"),
        ("[robot]\nsteering_divider = 4000000000", ""),
        (
            "[robot]\nspeed_window_steps = 0",
            "robot.speed_window_steps",
        ),
        (
            "[robot]\nspeed_window_steps = 4000000000",
            "robot.speed_window_steps",
        ),
        ("[robot]\nencoder_lines_per_motor_rev = 4294967295", ""),
    ];
    for (extra, key) in cases {
        match Scenario::from_toml(&format!("{base}\n{extra}\n"), "t.toml") {
            Err(e) => {
                let text = e.to_string();
                assert!(!key.is_empty() && text.contains(key), "{extra}: {text}");
            }
            Ok(mut s) => {
                assert!(key.is_empty(), "{extra}: accepted");
                s.duration_s = 0.05;
                let r = run_scenario_with(
                    &s,
                    controller_core::law::LawKind::Tracking,
                    RunOptions::at_steering_rate(&s),
                );
                assert!(r.is_ok(), "{extra}");
            }
        }
    }
    // 20 000 s at 10 kHz is 2e8 steps: refused by the step limit, not allocated.
    let long = base
        .replace("plant_rate_hz = 10000", "plant_rate_hz = 100000")
        .replace("duration_s = 30.0", "duration_s = 20000.0");
    let e = Scenario::from_toml(
        &format!("{long}\n[robot]\ncontrol_rate_hz = 10000\nspeed_window_steps = 64\n"),
        "t",
    )
    .unwrap_err()
    .to_string();
    assert!(e.starts_with("sim.duration_s"), "{e}");
}

/// `text` with `from` replaced by `to`, loaded: the error message, or `Ok`.
fn replaced(text: &str, from: &str, to: &str) -> Result<Scenario, String> {
    assert!(text.contains(from), "{from}");
    Scenario::from_toml(&text.replace(from, to), "t").map_err(|e| e.to_string())
}

fn replaced_error(text: &str, from: &str, to: &str) -> String {
    match replaced(text, from, to) {
        Ok(_) => panic!("accepted: {to}"),
        Err(e) => e,
    }
}

/// Fixed-length arrays: a wrong length, a non-number element or a non-array is an error
/// naming the key, not silently cut to the first elements.
#[test]
fn array_keys_take_exactly_their_numbers() {
    let circle = BUILTIN[0].1;
    let center = "center_m = [0.0, 0.0]";
    let cases = [
        (
            r#"center_m = [5.0, 0.0, "junk"]"#,
            "path.center_m must have exactly 2 numbers, got 3",
        ),
        (
            "center_m = [5.0, 0.0, 1.0]",
            "path.center_m must have exactly 2 numbers, got 3",
        ),
        (
            "center_m = [5.0]",
            "path.center_m must have exactly 2 numbers, got 1",
        ),
        (
            "center_m = []",
            "path.center_m must have exactly 2 numbers, got 0",
        ),
        (
            r#"center_m = [5.0, "junk"]"#,
            r#"path.center_m[1] must be a number, got string "junk""#,
        ),
        (
            "center_m = [[1.0, 2.0], 0.0]",
            "path.center_m[0] must be a number, got an array of 2 elements",
        ),
        (
            "center_m = 5.0",
            "path.center_m must be an array of 2 numbers, got 5",
        ),
        (
            "center_m = { x = 1.0 }",
            "path.center_m must be an array of 2 numbers, got a table",
        ),
        (
            "center_m = [nan, 0.0]",
            "path.center_m[0] must be finite, got NaN",
        ),
    ];
    for (to, expected) in cases {
        assert_eq!(replaced_error(circle, center, to), expected, "{to}");
    }
    // Integers are numbers.
    let s = replaced(circle, center, "center_m = [1, -2]").unwrap();
    let p = s.path.sample(0.0).point;
    let r = 1.25;
    let from_centre = ((p.x_m - 1.0).powi(2) + (p.y_m + 2.0).powi(2)).sqrt();
    assert!((from_centre - r).abs() < 1e-5, "{p:?}");

    let line = BUILTIN[1].1;
    let start = "start_m = [0.0, 0.0]";
    assert_eq!(
        replaced_error(line, start, "start_m = [0.0, 0.0, 1.0]"),
        "path.start_m must have exactly 2 numbers, got 3"
    );
    assert_eq!(
        replaced_error(line, start, "start_m = [true, 0.0]"),
        "path.start_m[0] must be a number, got boolean true"
    );
    let s = replaced(line, start, "start_m = [1, -2]").unwrap();
    let p = s.path.sample(0.0).point;
    assert_eq!((p.x_m, p.y_m), (1.0, -2.0));

    let square = BUILTIN[2].1;
    let second = "[2.0, 0.0], [2.0, 2.0]";
    assert_eq!(
        replaced_error(square, second, "[2.0, 0.0, 9.0], [2.0, 2.0]"),
        "path.waypoints_m[1] must have exactly 2 numbers, got 3"
    );
    assert_eq!(
        replaced_error(square, second, "[2.0], [2.0, 2.0]"),
        "path.waypoints_m[1] must have exactly 2 numbers, got 1"
    );
    assert_eq!(
        replaced_error(square, second, r#"[2.0, 0.0], [2.0, "x"]"#),
        r#"path.waypoints_m[2][1] must be a number, got string "x""#
    );
    assert_eq!(
        replaced_error(square, second, "7, [2.0, 2.0]"),
        "path.waypoints_m[1] must be an array of 2 numbers, got 7"
    );
    let all = "waypoints_m = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]";
    assert_eq!(
        replaced_error(square, all, "waypoints_m = 5"),
        "path.waypoints_m must be an array of [x, y] points, got 5"
    );
}

#[test]
fn driver_supply_and_centre_of_mass_are_checked_with_their_key() {
    // Defaults: the TB6612 with the firmware's 5 000-level PWM, centre of mass on the axle.
    let s = with("").unwrap();
    assert_eq!(s.plant.driver.kind, DriverKind::Tb6612);
    assert_eq!(s.plant.driver.pwm_levels, 5000);
    assert_eq!(s.plant.body.com_ahead_of_axle_m, 0.0);

    let s = with("[plant]\ndriver = \"drv8833\"\nsupply_v = 7.4").unwrap();
    assert_eq!(s.plant.driver.kind, DriverKind::Drv8833);
    // The robot's supply limit follows the bridge, as on the firmware: the DRV8833's
    // 10.8 V rating by default (13.5 V, the TB6612FNG's, otherwise), never above it.
    assert_eq!(s.robot.drive.max_supply_v, 10.8);
    assert_eq!(with("").unwrap().robot.drive.max_supply_v, 13.5);
    assert_eq!(
        error("[robot.drive]\nmax_supply_v = 12.6\n[plant]\ndriver = \"drv8833\"\nsupply_v = 7.4"),
        "robot.drive.max_supply_v must be ≤ 10.8 V, the drv8833's rating (plant.driver), got 12.6"
    );
    let e = error("[plant]\ndriver = \"l298n\"");
    assert!(
        e.contains("driver") && e.contains("unknown variant `l298n`"),
        "{e}"
    );
    assert_eq!(
        error("[plant]\ndriver = \"drv8833\"\nsupply_v = 12.0"),
        "plant.supply_v must be ≤ 11.8 V, the drv8833's absolute maximum (plant.driver), got 12"
    );
    assert_eq!(
        error("[plant]\nsupply_v = 16.0"),
        "plant.supply_v must be ≤ 15 V, the tb6612's absolute maximum (plant.driver), got 16"
    );
    assert_eq!(
        error("[plant]\npwm_levels = 0"),
        "plant.pwm_levels must be > 0, got 0"
    );
    assert_eq!(
        error("[plant.body]\ncom_ahead_of_axle_m = nan"),
        "plant.body.com_ahead_of_axle_m must be finite, got NaN"
    );
    // 0.5 kg at 0.1 m is 5e-3 kg·m², more than the whole 1.8e-3 kg·m² about the axle.
    let e = error("[plant.body]\ncom_ahead_of_axle_m = 0.1");
    assert!(
        e.starts_with(
            "plant.body.com_ahead_of_axle_m must satisfy mass_kg · d² ≤ yaw_inertia_kg_m2"
        ) && e.ends_with("got 0.1"),
        "{e}"
    );
    // An offset centre of mass loads and runs.
    let mut s = with("[plant.body]\ncom_ahead_of_axle_m = -0.03").unwrap();
    assert_eq!(s.plant.body.com_ahead_of_axle_m, -0.03);
    s.duration_s = 0.5;
    let r = run_scenario_with(
        &s,
        controller_core::law::LawKind::Tracking,
        RunOptions::at_steering_rate(&s),
    );
    assert!(r.is_ok());
}

#[test]
fn the_plant_can_be_lifted_and_only_by_name() {
    use robot_files::plant::Load;
    assert_eq!(with("").unwrap().plant.load, Load::Ground);
    let lifted = with("[plant]\nload = \"lifted\"").unwrap();
    assert_eq!(lifted.plant.load, Load::Lifted);
    // Lifted, the robot does not move, whatever the wheels do.
    let mut short = lifted.with_duration_s(0.5).unwrap();
    short.faults.clear();
    let run = run_scenario_with(
        &short,
        controller_core::law::LawKind::Tracking,
        RunOptions::traced_every(10),
    )
    .unwrap();
    let first = run.trace.first().unwrap().true_pose;
    let last = run.trace.last().unwrap();
    assert_eq!(first, last.true_pose);
    assert!(last.true_wheel[0].abs() > 1.0, "{:?}", last.true_wheel);
    assert!(error("[plant]\nload = \"flying\"").contains("load"));
}
