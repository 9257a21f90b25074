//! From the file as read ([`ScenarioFile`]) to a validated [`Scenario`]: every value
//! checked with its key (the rules are in `checks`), the robot and supervisor sections by
//! the core's own validation, the path and reference built by the core.

use controller_core::params::RobotConfig;
use controller_core::path::Path;
use controller_core::prelude::{Pose, Reference};
use controller_core::reference::ReferenceMode;

use super::checks::{
    as_f32, check, check_duration, coordinate, finite, in_range, length, length_or_zero,
    non_negative, optional_point, path_error, point, positive, required,
};
use super::raw_value::{array, numbers};
use super::schema::{
    ArmAtStart, DriverName, FilePath, FilePlant, FileSweep, LoadName, ModeName, PathKind,
    ScenarioFile,
};
use super::{
    Mismatch, PlantSpec, Scenario, ScenarioError, StartState, SweepSpec, MAX_CONTROL_RATE_HZ,
    MAX_EDGE_JITTER_TICKS_RMS,
};
use crate::plant::{BodyParams, DriverKind, DriverParams, Load, MotorMismatch, MotorParams};
use crate::robot_file::PathContext;

/// The path `[path]` describes, world frame.
fn build_path(p: &FilePath) -> Result<Path, ScenarioError> {
    let used: &[&str] = match p.kind {
        PathKind::Circle => &[
            "center_m",
            "radius_m",
            "start_angle_rad",
            "counter_clockwise",
        ],
        PathKind::Line => &["start_m", "heading_rad", "length_m"],
        PathKind::Polyline => &["waypoints_m", "corner_radius_m", "closed"],
        PathKind::FigureEight => &["center_m", "lobe_radius_m"],
    };
    let present = [
        ("center_m", p.center_m.is_some()),
        ("radius_m", p.radius_m.is_some()),
        ("start_angle_rad", p.start_angle_rad.is_some()),
        ("counter_clockwise", p.counter_clockwise.is_some()),
        ("start_m", p.start_m.is_some()),
        ("heading_rad", p.heading_rad.is_some()),
        ("length_m", p.length_m.is_some()),
        ("waypoints_m", p.waypoints_m.is_some()),
        ("corner_radius_m", p.corner_radius_m.is_some()),
        ("closed", p.closed.is_some()),
        ("lobe_radius_m", p.lobe_radius_m.is_some()),
    ];
    let kind_name = match p.kind {
        PathKind::Circle => "circle",
        PathKind::Line => "line",
        PathKind::Polyline => "polyline",
        PathKind::FigureEight => "figure-eight",
    };
    if let Some((name, _)) = present.iter().find(|(n, set)| *set && !used.contains(n)) {
        return Err(ScenarioError::invalid(
            format!("path.{name}"),
            format!(
                "is not used by kind = \"{kind_name}\" (it takes {})",
                used.join(", ")
            ),
        ));
    }
    let path = match p.kind {
        PathKind::Circle => {
            let center = optional_point("path.center_m", p.center_m.as_ref())?;
            let r = length(
                "path.radius_m",
                required(p.radius_m, "path.radius_m", kind_name)?,
            )?;
            let a = finite("path.start_angle_rad", p.start_angle_rad.unwrap_or(0.0))?;
            Path::circle(
                center,
                as_f32("path.radius_m", r)?,
                as_f32("path.start_angle_rad", a)?,
                p.counter_clockwise.unwrap_or(true),
            )
        }
        PathKind::Line => {
            let raw = p.start_m.as_ref().ok_or_else(|| {
                ScenarioError::invalid("path.start_m", "is required for kind = \"line\"")
            })?;
            let start = point("path.start_m", numbers("path.start_m", raw)?)?;
            let h = finite("path.heading_rad", p.heading_rad.unwrap_or(0.0))?;
            let l = length(
                "path.length_m",
                required(p.length_m, "path.length_m", kind_name)?,
            )?;
            Path::line(
                start,
                as_f32("path.heading_rad", h)?,
                as_f32("path.length_m", l)?,
            )
        }
        PathKind::Polyline => {
            let raw = p.waypoints_m.as_ref().ok_or_else(|| {
                ScenarioError::invalid("path.waypoints_m", "is required for kind = \"polyline\"")
            })?;
            let raw = array("path.waypoints_m", raw, "[x, y] points")?;
            let mut points = Vec::with_capacity(raw.len());
            for (i, w) in raw.iter().enumerate() {
                let key = format!("path.waypoints_m[{i}]");
                points.push(point(&key, numbers(&key, w)?)?);
            }
            let r = length_or_zero("path.corner_radius_m", p.corner_radius_m.unwrap_or(0.0))?;
            Path::polyline(
                &points,
                as_f32("path.corner_radius_m", r)?,
                p.closed.unwrap_or(false),
            )
        }
        PathKind::FigureEight => {
            let center = optional_point("path.center_m", p.center_m.as_ref())?;
            let r = length(
                "path.lobe_radius_m",
                required(p.lobe_radius_m, "path.lobe_radius_m", kind_name)?,
            )?;
            Path::figure_eight(center, as_f32("path.lobe_radius_m", r)?)
        }
    };
    path.map_err(path_error)
}

/// The simulated robot `[plant]` describes, defaults for what it leaves out.
fn build_plant(p: &FilePlant) -> Result<PlantSpec, ScenarioError> {
    let d = PlantSpec::default();
    let m = &p.motor;
    let motor = MotorParams {
        resistance_ohm: positive(
            "plant.motor.resistance_ohm",
            m.resistance_ohm.unwrap_or(d.motor.resistance_ohm),
        )?,
        torque_constant_nm_per_a: positive(
            "plant.motor.torque_constant_nm_per_a",
            m.torque_constant_nm_per_a
                .unwrap_or(d.motor.torque_constant_nm_per_a),
        )?,
        back_emf_v_s_per_rad: positive(
            "plant.motor.back_emf_v_s_per_rad",
            m.back_emf_v_s_per_rad
                .unwrap_or(d.motor.back_emf_v_s_per_rad),
        )?,
        rotor_inertia_kg_m2: non_negative(
            "plant.motor.rotor_inertia_kg_m2",
            m.rotor_inertia_kg_m2.unwrap_or(d.motor.rotor_inertia_kg_m2),
        )?,
        gear_efficiency: {
            let v = m.gear_efficiency.unwrap_or(d.motor.gear_efficiency);
            check(
                v > 0.0 && v <= 1.0,
                "plant.motor.gear_efficiency",
                "must be in (0, 1]",
                v,
            )?;
            v
        },
        viscous_friction_nm_s_per_rad: non_negative(
            "plant.motor.viscous_friction_nm_s_per_rad",
            m.viscous_friction_nm_s_per_rad
                .unwrap_or(d.motor.viscous_friction_nm_s_per_rad),
        )?,
        coulomb_friction_nm: non_negative(
            "plant.motor.coulomb_friction_nm",
            m.coulomb_friction_nm.unwrap_or(d.motor.coulomb_friction_nm),
        )?,
    };
    let pwm_levels = p.pwm_levels.unwrap_or(d.driver.pwm_levels);
    check(
        pwm_levels > 0,
        "plant.pwm_levels",
        "must be > 0",
        pwm_levels,
    )?;
    let kind = match p.driver {
        None => d.driver.kind,
        Some(DriverName::Tb6612) => DriverKind::Tb6612,
        Some(DriverName::Drv8833) => DriverKind::Drv8833,
    };
    let supply_v = positive("plant.supply_v", p.supply_v.unwrap_or(d.driver.supply_v))?;
    check(
        supply_v <= kind.max_supply_v(),
        "plant.supply_v",
        &format!(
            "must be ≤ {} V, the {}'s absolute maximum (plant.driver)",
            kind.max_supply_v(),
            kind.name()
        ),
        supply_v,
    )?;
    let driver = DriverParams {
        kind,
        supply_v,
        pwm_levels,
        dead_band_duty: in_range(
            "plant.dead_band_duty",
            p.dead_band_duty.unwrap_or(d.driver.dead_band_duty),
            0.0,
            1.0,
            "must be in [0, 1)",
        )?,
    };
    let b = &p.body;
    let body = BodyParams {
        mass_kg: positive("plant.body.mass_kg", b.mass_kg.unwrap_or(d.body.mass_kg))?,
        yaw_inertia_kg_m2: non_negative(
            "plant.body.yaw_inertia_kg_m2",
            b.yaw_inertia_kg_m2.unwrap_or(d.body.yaw_inertia_kg_m2),
        )?,
        wheel_inertia_kg_m2: non_negative(
            "plant.body.wheel_inertia_kg_m2",
            b.wheel_inertia_kg_m2.unwrap_or(d.body.wheel_inertia_kg_m2),
        )?,
        com_ahead_of_axle_m: finite(
            "plant.body.com_ahead_of_axle_m",
            b.com_ahead_of_axle_m.unwrap_or(d.body.com_ahead_of_axle_m),
        )?,
    };
    // The yaw inertia is about the axle, so it contains the centre of mass' own m d².
    let d_com = body.com_ahead_of_axle_m;
    check(
        body.mass_kg * d_com * d_com <= body.yaw_inertia_kg_m2,
        "plant.body.com_ahead_of_axle_m",
        &format!(
            "must satisfy mass_kg · d² ≤ yaw_inertia_kg_m2 (the inertia about the axle includes m d²; |d| ≤ {:.4} m here)",
            (body.yaw_inertia_kg_m2 / body.mass_kg).sqrt()
        ),
        d_com,
    )?;
    let pct = |key: &str, v: Option<f64>| {
        in_range(
            key,
            v.unwrap_or(0.0),
            -50.0,
            50.0 + f64::EPSILON,
            "must be in [-50, 50] %",
        )
    };
    let mismatch = Mismatch {
        wheel_radius_pct: pct(
            "plant.mismatch.wheel_radius_pct",
            p.mismatch.wheel_radius_pct,
        )?,
        wheel_radius_left_right_pct: pct(
            "plant.mismatch.wheel_radius_left_right_pct",
            p.mismatch.wheel_radius_left_right_pct,
        )?,
        track_width_pct: pct("plant.mismatch.track_width_pct", p.mismatch.track_width_pct)?,
    };
    let mm = &p.motor_mismatch;
    let motor_mismatch = MotorMismatch {
        resistance_left_right_pct: pct(
            "plant.motor_mismatch.resistance_left_right_pct",
            mm.resistance_left_right_pct,
        )?,
        torque_constant_left_right_pct: pct(
            "plant.motor_mismatch.torque_constant_left_right_pct",
            mm.torque_constant_left_right_pct,
        )?,
        viscous_friction_left_right_pct: pct(
            "plant.motor_mismatch.viscous_friction_left_right_pct",
            mm.viscous_friction_left_right_pct,
        )?,
        coulomb_friction_left_right_pct: pct(
            "plant.motor_mismatch.coulomb_friction_left_right_pct",
            mm.coulomb_friction_left_right_pct,
        )?,
    };
    let slip = [
        in_range(
            "plant.slip.left",
            p.slip.left.unwrap_or(0.0),
            0.0,
            1.0,
            "must be in [0, 1)",
        )?,
        in_range(
            "plant.slip.right",
            p.slip.right.unwrap_or(0.0),
            0.0,
            1.0,
            "must be in [0, 1)",
        )?,
    ];
    let encoder_noise_ticks_rms = jitter(
        "plant.encoder_noise_ticks_rms",
        p.encoder_noise_ticks_rms.unwrap_or(0.0),
    )?;
    Ok(PlantSpec {
        motor,
        driver,
        body,
        mismatch,
        motor_mismatch,
        slip,
        encoder_noise_ticks_rms,
        load: match p.load {
            None | Some(LoadName::Ground) => Load::Ground,
            Some(LoadName::Lifted) => Load::Lifted,
        },
    })
}

/// `v`, an encoder edge jitter in ticks RMS, if the simulator models it (at most
/// [`MAX_EDGE_JITTER_TICKS_RMS`]).
fn jitter(key: &str, v: f64) -> Result<f64, ScenarioError> {
    check(
        (0.0..=MAX_EDGE_JITTER_TICKS_RMS).contains(&v),
        key,
        &format!(
            "must be in [0, {MAX_EDGE_JITTER_TICKS_RMS}] (each edge within a tick of its place)"
        ),
        v,
    )?;
    Ok(v)
}

/// The Monte-Carlo spreads `[sweep]` describes, defaults for what it leaves out.
fn build_sweep(s: &FileSweep) -> Result<SweepSpec, ScenarioError> {
    let d = SweepSpec::DEFAULT;
    let spread = |key: &str, v: Option<f64>, default: f64, max: f64| {
        let v = v.unwrap_or(default);
        check(
            v >= 0.0 && v <= max,
            key,
            &format!("must be in [0, {max}]"),
            v,
        )?;
        Ok::<f64, ScenarioError>(v)
    };
    Ok(SweepSpec {
        wheel_radius_pct: spread(
            "sweep.wheel_radius_pct",
            s.wheel_radius_pct,
            d.wheel_radius_pct,
            20.0,
        )?,
        wheel_radius_left_right_pct: spread(
            "sweep.wheel_radius_left_right_pct",
            s.wheel_radius_left_right_pct,
            d.wheel_radius_left_right_pct,
            20.0,
        )?,
        track_width_pct: spread(
            "sweep.track_width_pct",
            s.track_width_pct,
            d.track_width_pct,
            20.0,
        )?,
        supply_pct: spread("sweep.supply_pct", s.supply_pct, d.supply_pct, 50.0)?,
        coulomb_friction_pct: spread(
            "sweep.coulomb_friction_pct",
            s.coulomb_friction_pct,
            d.coulomb_friction_pct,
            100.0,
        )?,
        motor_left_right_pct: spread(
            "sweep.motor_left_right_pct",
            s.motor_left_right_pct,
            d.motor_left_right_pct,
            20.0,
        )?,
        slip_max: spread("sweep.slip_max", s.slip_max, d.slip_max, 0.5)?,
        encoder_noise_ticks_rms_max: spread(
            "sweep.encoder_noise_ticks_rms_max",
            s.encoder_noise_ticks_rms_max,
            d.encoder_noise_ticks_rms_max,
            MAX_EDGE_JITTER_TICKS_RMS,
        )?,
        start_position_m: spread(
            "sweep.start_position_m",
            s.start_position_m,
            d.start_position_m,
            10.0,
        )?,
        start_heading_rad: spread(
            "sweep.start_heading_rad",
            s.start_heading_rad,
            d.start_heading_rad,
            core::f64::consts::PI,
        )?,
    })
}

/// The scenario `file` describes, named `default_name` unless it names itself.
pub(super) fn build(file: ScenarioFile, default_name: &str) -> Result<Scenario, ScenarioError> {
    // The robot's supply limit follows the bridge, as on the firmware: by default the
    // chip's operating maximum, and never above it.
    let plant = build_plant(&file.plant)?;
    let bridge_max_v = plant.driver.kind.operating_supply_v().1 as f32;
    let mut base = RobotConfig::REFERENCE_ROBOT;
    base.drive.max_supply_v = base.drive.max_supply_v.min(bridge_max_v);
    let mut robot = file.robot.apply(base);
    check(
        robot.drive.max_supply_v <= bridge_max_v,
        "robot.drive.max_supply_v",
        &format!(
            "must be ≤ {bridge_max_v} V, the {}'s rating (plant.driver)",
            plant.driver.kind.name()
        ),
        robot.drive.max_supply_v,
    )?;
    // The simulator's own limit first: an absurd rate is refused as such.
    check(
        robot.control_rate_hz <= MAX_CONTROL_RATE_HZ,
        "robot.control_rate_hz",
        &format!("must be ≤ {MAX_CONTROL_RATE_HZ}"),
        robot.control_rate_hz,
    )?;
    // The core is the single source of truth for what a valid RobotConfig is.
    let params = file.robot.params(base, "robot")?;

    let duration_s = file.sim.duration_s.unwrap_or(30.0);
    let control = robot.control_rate_hz;
    check_duration(duration_s, control)?;
    let plant_rate_hz = file.sim.plant_rate_hz.unwrap_or(control.saturating_mul(10));
    check(
        plant_rate_hz % control == 0 && plant_rate_hz / control >= 10,
        "sim.plant_rate_hz",
        &format!("must be a multiple of robot.control_rate_hz ({control}) and at least 10× it"),
        plant_rate_hz,
    )?;

    let path = build_path(&file.path)?;

    let r = &file.reference;
    let speed = as_f32(
        "reference.speed_m_s",
        positive("reference.speed_m_s", r.speed_m_s)?,
    )?;
    let reference_mode = match r.mode {
        ModeName::TimeIndexed => {
            if r.lookahead_m.is_some() {
                return Err(ScenarioError::invalid(
                    "reference.lookahead_m",
                    "is only used with mode = \"path-following\"",
                ));
            }
            ReferenceMode::TimeIndexed {
                start_offset_m: as_f32(
                    "reference.start_offset_m",
                    length_or_zero("reference.start_offset_m", r.start_offset_m.unwrap_or(0.0))?,
                )?,
            }
        }
        ModeName::PathFollowing => {
            if r.start_offset_m.is_some() {
                return Err(ScenarioError::invalid(
                    "reference.start_offset_m",
                    "is only used with mode = \"time-indexed\"",
                ));
            }
            ReferenceMode::PathFollowing {
                lookahead_m: as_f32(
                    "reference.lookahead_m",
                    length_or_zero("reference.lookahead_m", r.lookahead_m.unwrap_or(0.0))?,
                )?,
            }
        }
    };

    let s = &file.start;
    // x and y are bounded by `coordinate` below, well inside f32.
    for (key, v) in [
        ("start.theta_rad", s.theta_rad),
        ("start.v_m_s", s.v_m_s),
        ("start.omega_rad_s", s.omega_rad_s),
    ] {
        as_f32(key, v)?;
    }
    let start = StartState {
        x_m: coordinate("start.x_m", s.x_m)?,
        y_m: coordinate("start.y_m", s.y_m)?,
        theta_rad: finite("start.theta_rad", s.theta_rad)?,
        v_m_s: finite("start.v_m_s", s.v_m_s)?,
        omega_rad_s: finite("start.omega_rad_s", s.omega_rad_s)?,
    };
    // The initial wheel speeds must be within what the encoder check accepts.
    let half = 0.5 * start.omega_rad_s.abs() * f64::from(robot.track_width_m);
    let smaller_wheel = robot.wheel_radius_left_m.min(robot.wheel_radius_right_m);
    let fastest = (start.v_m_s.abs() + half) / f64::from(smaller_wheel);
    check(
        fastest < f64::from(robot.max_plausible_wheel_speed_rad_s),
        "start.v_m_s",
        &format!(
            "with start.omega_rad_s needs a wheel speed below robot.max_plausible_wheel_speed_rad_s ({})",
            robot.max_plausible_wheel_speed_rad_s
        ),
        start.v_m_s,
    )?;

    let reference = Reference::new(path.clone(), speed, reference_mode)
        .map_err(|e| ScenarioError::invalid("reference", format!("is not valid: {e}")))?;
    let start_pose = Pose::new(start.x_m as f32, start.y_m as f32, start.theta_rad as f32);
    let context = PathContext {
        reference: &reference,
        start: start_pose,
    };
    let supervisor = file
        .supervisor
        .config(&params, Some(context), "supervisor")?;

    // The [gyro] table's heading and full scale are the robot's (its `gyro`), as a robot
    // file or the link would set them; a full scale [gyro] omits is [robot.gyro]'s.
    let gyro = file
        .gyro
        .as_ref()
        .map(|g| g.build(robot.gyro.full_scale_radps))
        .transpose()?;
    if let Some(setup) = &gyro {
        robot.gyro = setup.robot_gyro(robot.gyro);
    }
    Ok(Scenario {
        name: file.name.unwrap_or_else(|| default_name.to_string()),
        description: file.description,
        duration_s,
        plant_rate_hz,
        seed: file.sim.seed.unwrap_or(1),
        path,
        reference_speed_m_s: speed,
        reference_mode,
        start,
        robot,
        supervisor,
        plant,
        arm_at_start: file.start.arm == ArmAtStart::AtStart,
        faults: file
            .faults
            .iter()
            .enumerate()
            .map(|(i, f)| f.build(i, control))
            .collect::<Result<_, _>>()
            .map_err(|e| ScenarioError::invalid(e.key, e.problem))?,
        sweep: build_sweep(&file.sweep)?,
        gyro,
        velocity: match &file.velocity {
            Some(v) => Some(super::velocity::build(v, control)?),
            None => None,
        },
        miswire: file.virtual_robot.miswire,
    })
}
