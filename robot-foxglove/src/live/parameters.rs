//! The robot's parameters as a Foxglove parameter set: a robot file (the `[robot]` and
//! `[supervisor]` TOML that `station params get` prints) flattened to dotted names
//! (`robot.wheel_radius_left_m`, `supervisor.stall.timeout_s`, …), numbers as numbers.
//!
//! A client's change is not applied here: while the robot is disarmed it is queued, and
//! the owner of the link takes it ([`RobotParameters::take_changes`]), writes it into the
//! robot file ([`apply_changes`]), has the robot check and apply it, and publishes what
//! the robot then runs. While the robot is armed the set is read-only: a change is
//! answered with the values unchanged.

use std::sync::Mutex;

use foxglove::websocket::{
    AnyClient, GetParametersResponder, Parameter, ParameterHandler, ParameterValue,
    SetParametersResponder,
};

/// One change a client asked for: the dotted name and the value in the robot file's type.
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterChange {
    /// The dotted name (`robot.max_speed_m_s`).
    pub name: String,
    /// The new value.
    pub value: toml::Value,
}

/// Why a change could not be written into the robot file.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ParameterError {
    /// The robot file is not TOML (the parser's message).
    #[error("robot file: {0}")]
    File(String),
    /// No such parameter.
    #[error("parameter {0}: no such parameter")]
    Unknown(String),
    /// The value is not of the parameter's type.
    #[error("parameter {name}: {expected} expected")]
    Type {
        /// The dotted name.
        name: String,
        /// What the parameter holds.
        expected: &'static str,
    },
}

#[derive(Default)]
struct State {
    table: toml::Table,
    read_only: bool,
    changes: Vec<ParameterChange>,
}

/// The parameter set (module doc), shared with the server's handler threads.
#[derive(Default)]
pub struct RobotParameters {
    state: Mutex<State>,
}

impl RobotParameters {
    /// The set of `robot_file` (TOML; text that does not parse gives an empty set).
    pub fn new(robot_file: &str) -> Self {
        let parameters = Self::default();
        parameters.replace(robot_file);
        parameters
    }

    /// Replaces the set by `robot_file`'s; returns its values.
    pub fn replace(&self, robot_file: &str) -> Vec<Parameter> {
        let table = robot_file.parse::<toml::Table>().unwrap_or_default();
        let values = flatten(&table);
        self.with_state(|s| s.table = table);
        values
    }

    /// Makes the set read-only (while the robot is armed) or writable.
    pub fn set_read_only(&self, read_only: bool) {
        self.with_state(|s| s.read_only = read_only);
    }

    /// True while the set is read-only.
    pub fn read_only(&self) -> bool {
        self.with_state(|s| s.read_only)
    }

    /// The values, every parameter in name order.
    pub fn values(&self) -> Vec<Parameter> {
        self.with_state(|s| flatten(&s.table))
    }

    /// The queued changes, oldest first; the queue is emptied.
    pub fn take_changes(&self) -> Vec<ParameterChange> {
        self.with_state(|s| std::mem::take(&mut s.changes))
    }

    /// Queues what `parameters` ask, unless the set is read-only; each is converted to
    /// its parameter's type, and one that is unknown or of another type is dropped.
    /// Returns how many were queued.
    pub fn request(&self, parameters: &[Parameter]) -> usize {
        self.with_state(|s| {
            if s.read_only {
                return 0;
            }
            let mut queued = 0;
            for p in parameters {
                let Some(value) = &p.value else { continue };
                if let Ok(value) = converted(&s.table, &p.name, value) {
                    s.changes.push(ParameterChange {
                        name: p.name.clone(),
                        value,
                    });
                    queued += 1;
                }
            }
            queued
        })
    }

    fn with_state<R>(&self, f: impl FnOnce(&mut State) -> R) -> R {
        // A handler thread that panicked holding the lock left a consistent table.
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        f(&mut state)
    }
}

impl ParameterHandler for RobotParameters {
    fn get(
        &self,
        _client: AnyClient,
        names: Vec<String>,
        _request_id: Option<String>,
        responder: GetParametersResponder,
    ) {
        responder.respond(selected(self.values(), &names));
    }

    fn set(
        &self,
        _client: AnyClient,
        parameters: Vec<Parameter>,
        _request_id: Option<String>,
        responder: SetParametersResponder,
    ) {
        self.request(&parameters);
        // Nothing is applied yet: the values as they are; the owner publishes the new
        // ones once the robot runs them.
        let names: Vec<String> = parameters.into_iter().map(|p| p.name).collect();
        responder.respond(selected(self.values(), &names));
    }
}

/// The parameters of `values` named in `names` (all of them when `names` is empty).
fn selected(values: Vec<Parameter>, names: &[String]) -> Vec<Parameter> {
    if names.is_empty() {
        return values;
    }
    values
        .into_iter()
        .filter(|p| names.contains(&p.name))
        .collect()
}

/// Every number, boolean, string and array of numbers in `table`, by dotted name, in
/// name order.
fn flatten(table: &toml::Table) -> Vec<Parameter> {
    let mut out = Vec::new();
    flatten_into(table, "", &mut out);
    out.sort_by(|a, b| a.name.cmp(&b.name));
    out
}

fn flatten_into(table: &toml::Table, prefix: &str, out: &mut Vec<Parameter>) {
    for (key, value) in table {
        let name = if prefix.is_empty() {
            key.clone()
        } else {
            format!("{prefix}.{key}")
        };
        match value {
            toml::Value::Table(inner) => flatten_into(inner, &name, out),
            toml::Value::Integer(i) => out.push(Parameter::integer(name, *i)),
            toml::Value::Float(f) => out.push(Parameter::float64(name, *f)),
            toml::Value::Boolean(b) => out.push(Parameter::bool(name, *b)),
            toml::Value::String(s) => out.push(Parameter::string(name, s.clone())),
            toml::Value::Array(items) => {
                let numbers: Option<Vec<f64>> = items.iter().map(number).collect();
                if let Some(numbers) = numbers {
                    out.push(Parameter::float64_array(name, numbers));
                }
            }
            toml::Value::Datetime(_) => {}
        }
    }
}

fn number(value: &toml::Value) -> Option<f64> {
    match value {
        toml::Value::Integer(i) => Some(*i as f64),
        toml::Value::Float(f) => Some(*f),
        _ => None,
    }
}

/// The value at dotted `name` of `table`.
fn lookup<'a>(table: &'a toml::Table, name: &str) -> Option<&'a toml::Value> {
    let (head, rest) = match name.split_once('.') {
        Some((head, rest)) => (head, Some(rest)),
        None => (name, None),
    };
    let value = table.get(head)?;
    match (rest, value) {
        (None, v) => Some(v),
        (Some(rest), toml::Value::Table(inner)) => lookup(inner, rest),
        _ => None,
    }
}

/// `value` as the type of the parameter `name` holds in `table`.
fn converted(
    table: &toml::Table,
    name: &str,
    value: &ParameterValue,
) -> Result<toml::Value, ParameterError> {
    let current = lookup(table, name).ok_or_else(|| ParameterError::Unknown(name.to_string()))?;
    let wrong = |expected| ParameterError::Type {
        name: name.to_string(),
        expected,
    };
    let as_f64 = |v: &ParameterValue| match v {
        ParameterValue::Float64(f) => Some(*f),
        ParameterValue::Integer(i) => Some(*i as f64),
        _ => None,
    };
    Ok(match current {
        toml::Value::Float(_) => toml::Value::Float(as_f64(value).ok_or(wrong("a number"))?),
        toml::Value::Integer(_) => {
            let f = as_f64(value).ok_or(wrong("an integer"))?;
            if f.fract() != 0.0 || !f.is_finite() {
                return Err(wrong("an integer"));
            }
            toml::Value::Integer(f as i64)
        }
        toml::Value::Boolean(_) => match value {
            ParameterValue::Bool(b) => toml::Value::Boolean(*b),
            _ => return Err(wrong("a boolean")),
        },
        toml::Value::String(_) => match value {
            ParameterValue::String(s) => toml::Value::String(s.clone()),
            _ => return Err(wrong("a string")),
        },
        toml::Value::Array(_) => match value {
            ParameterValue::Array(items) => toml::Value::Array(
                items
                    .iter()
                    .map(|v| as_f64(v).map(toml::Value::Float))
                    .collect::<Option<Vec<_>>>()
                    .ok_or(wrong("an array of numbers"))?,
            ),
            _ => return Err(wrong("an array of numbers")),
        },
        _ => return Err(wrong("a value the robot file holds")),
    })
}

/// `robot_file` with `changes` written in (each at its dotted name, which must exist):
/// the robot file the owner sends to the robot.
pub fn apply_changes(
    robot_file: &str,
    changes: &[ParameterChange],
) -> Result<String, ParameterError> {
    let mut table = robot_file
        .parse::<toml::Table>()
        .map_err(|e| ParameterError::File(e.message().to_string()))?;
    for change in changes {
        let unknown = || ParameterError::Unknown(change.name.clone());
        let mut keys: Vec<&str> = change.name.split('.').collect();
        let last = keys.pop().ok_or_else(unknown)?;
        let mut inner = &mut table;
        for key in keys {
            inner = match inner.get_mut(key) {
                Some(toml::Value::Table(t)) => t,
                _ => return Err(unknown()),
            };
        }
        match inner.get_mut(last) {
            Some(slot) => *slot = change.value.clone(),
            None => return Err(unknown()),
        }
    }
    toml::to_string(&table).map_err(|e| ParameterError::File(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = "[robot]\nwheel_radius_left_m = 0.03\ncontrol_rate_hz = 1000\n\
        [robot.limits]\nmax_speed_m_s = 0.5\n[supervisor]\nauto_arm = false\n";

    fn float(p: &Parameter) -> Option<f64> {
        match p.value {
            Some(ParameterValue::Float64(f)) => Some(f),
            _ => None,
        }
    }

    #[test]
    fn a_robot_file_is_flattened_to_dotted_names() {
        let set = RobotParameters::new(FILE);
        let values = set.values();
        let names: Vec<&str> = values.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "robot.control_rate_hz",
                "robot.limits.max_speed_m_s",
                "robot.wheel_radius_left_m",
                "supervisor.auto_arm"
            ]
        );
        assert_eq!(float(&values[1]), Some(0.5));
    }

    #[test]
    fn changes_are_queued_while_disarmed_and_refused_while_armed() {
        let set = RobotParameters::new(FILE);
        let ask = [Parameter::float64("robot.limits.max_speed_m_s", 0.4)];
        set.set_read_only(true);
        assert_eq!(set.request(&ask), 0);
        assert!(set.take_changes().is_empty());
        set.set_read_only(false);
        // An unknown name and a wrong type are dropped; an integer given as 1000.0 kept.
        let mixed = [
            ask[0].clone(),
            Parameter::float64("robot.no_such_key", 1.0),
            Parameter::bool("robot.wheel_radius_left_m", true),
            Parameter::float64("robot.control_rate_hz", 500.0),
        ];
        assert_eq!(set.request(&mixed), 2);
        let changes = set.take_changes();
        assert_eq!(changes[0].value, toml::Value::Float(0.4));
        assert_eq!(changes[1].value, toml::Value::Integer(500));
        let text = apply_changes(FILE, &changes).expect("applies");
        let again = RobotParameters::new(&text);
        let speed = again
            .values()
            .into_iter()
            .find(|p| p.name == "robot.limits.max_speed_m_s")
            .and_then(|p| float(&p));
        assert_eq!(speed, Some(0.4));
        let unknown = ParameterChange {
            name: "robot.limits.nope".into(),
            value: toml::Value::Float(1.0),
        };
        assert_eq!(
            apply_changes(FILE, &[unknown]),
            Err(ParameterError::Unknown("robot.limits.nope".into()))
        );
    }
}
