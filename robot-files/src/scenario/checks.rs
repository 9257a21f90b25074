//! The rules a scenario's values are checked against. Each takes the dotted key of the
//! value and, when the value breaks the rule, returns a [`ScenarioError::Invalid`] naming
//! the key, the rule and the value (`robot.wheel_radius_m must be > 0, got -0.03`).

use std::fmt;

use controller_core::path::PathError;
use controller_core::prelude::Point;

use super::raw_value::{numbers, RawValue};
use super::{ScenarioError, MAX_CONTROL_STEPS, MAX_DURATION_S, MAX_POSITION_M};

/// `sim.duration_s` (s) at a control rate of `control_hz`: in (0, 24 h] and within the
/// simulator's step budget.
pub(super) fn check_duration(duration_s: f64, control_hz: u32) -> Result<(), ScenarioError> {
    check(
        duration_s > 0.0 && duration_s <= MAX_DURATION_S,
        "sim.duration_s",
        &format!("must be in (0, {MAX_DURATION_S}]"),
        duration_s,
    )?;
    check(
        duration_s * f64::from(control_hz) <= MAX_CONTROL_STEPS,
        "sim.duration_s",
        &format!(
            "times robot.control_rate_hz ({control_hz}) must be ≤ {MAX_CONTROL_STEPS:e} control steps"
        ),
        duration_s,
    )
}

/// `Ok` when `ok`; else the error "`key` `rule`, got `value`".
pub(super) fn check(
    ok: bool,
    key: &str,
    rule: &str,
    value: impl fmt::Display,
) -> Result<(), ScenarioError> {
    if ok {
        Ok(())
    } else {
        Err(ScenarioError::invalid(key, format!("{rule}, got {value}")))
    }
}

/// `v` if finite and > 0.
pub(super) fn positive(key: &str, v: f64) -> Result<f64, ScenarioError> {
    check(v > 0.0 && v.is_finite(), key, "must be > 0", v)?;
    Ok(v)
}

/// `v` if finite and ≥ 0.
pub(super) fn non_negative(key: &str, v: f64) -> Result<f64, ScenarioError> {
    check(v >= 0.0 && v.is_finite(), key, "must be ≥ 0", v)?;
    Ok(v)
}

/// `v` if finite.
pub(super) fn finite(key: &str, v: f64) -> Result<f64, ScenarioError> {
    check(v.is_finite(), key, "must be finite", v)?;
    Ok(v)
}

/// `v` if finite and in [`lo`, `hi`); `rule` says so in the error.
pub(super) fn in_range(
    key: &str,
    v: f64,
    lo: f64,
    hi: f64,
    rule: &str,
) -> Result<f64, ScenarioError> {
    check(v >= lo && v < hi && v.is_finite(), key, rule, v)?;
    Ok(v)
}

/// `v` as it reads in an error: exponent notation from 1e6 up (1e30, not 31 digits).
fn shown(v: f64) -> String {
    if v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

/// `v` (m, a coordinate of a position) if finite and within ±[`MAX_POSITION_M`].
pub(super) fn coordinate(key: &str, v: f64) -> Result<f64, ScenarioError> {
    finite(key, v)?;
    check(
        v.abs() <= MAX_POSITION_M,
        key,
        &format!("must be within ±{MAX_POSITION_M} m of the origin"),
        shown(v),
    )?;
    Ok(v)
}

/// `v` (m, a length) if finite, > 0 and ≤ [`MAX_POSITION_M`].
pub(super) fn length(key: &str, v: f64) -> Result<f64, ScenarioError> {
    at_most_world(key, positive(key, v)?)
}

/// `v` (m, a length that may be 0) if finite, ≥ 0 and ≤ [`MAX_POSITION_M`].
pub(super) fn length_or_zero(key: &str, v: f64) -> Result<f64, ScenarioError> {
    at_most_world(key, non_negative(key, v)?)
}

fn at_most_world(key: &str, v: f64) -> Result<f64, ScenarioError> {
    check(
        v <= MAX_POSITION_M,
        key,
        &format!("must be ≤ {MAX_POSITION_M} m"),
        shown(v),
    )?;
    Ok(v)
}

/// `v` as the f32 the controller uses; an error naming `key` if it does not fit.
pub(super) fn as_f32(key: &str, v: f64) -> Result<f32, ScenarioError> {
    let f = v as f32;
    check(
        f.is_finite() || !v.is_finite(),
        key,
        "is beyond the f32 range of the controller (±3.4e38)",
        v,
    )?;
    Ok(f)
}

/// The value of `key`, which `kind` of path requires.
pub(super) fn required<T: Copy>(
    value: Option<T>,
    key: &str,
    kind: &str,
) -> Result<T, ScenarioError> {
    value.ok_or_else(|| ScenarioError::invalid(key, format!("is required for kind = \"{kind}\"")))
}

/// The point at `key`, (0, 0) if the key is absent.
pub(super) fn optional_point(key: &str, raw: Option<&RawValue>) -> Result<Point, ScenarioError> {
    point(key, raw.map_or(Ok([0.0, 0.0]), |raw| numbers(key, raw))?)
}

/// `p` (m, world frame) as the controller's point; each coordinate a [`coordinate`], its
/// error naming `key[0]` or `key[1]`.
pub(super) fn point(key: &str, p: [f64; 2]) -> Result<Point, ScenarioError> {
    let x = as_f32(
        &format!("{key}[0]"),
        coordinate(&format!("{key}[0]"), p[0])?,
    )?;
    let y = as_f32(
        &format!("{key}[1]"),
        coordinate(&format!("{key}[1]"), p[1])?,
    )?;
    Ok(Point::new(x, y))
}

/// The core's refusal of a path, as an error on `path`.
pub(super) fn path_error(e: PathError) -> ScenarioError {
    ScenarioError::invalid("path", format!("is not a valid path: {e}"))
}
