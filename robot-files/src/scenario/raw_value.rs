//! Fixed-length number arrays. serde reads `[f64; N]` as a tuple of N elements, and the
//! `toml` crate (1.x) does not check that the array ends there: `center_m = [5.0, 0.0,
//! "junk"]` read as (5, 0). So every such key is read as a [`RawValue`], which accepts any
//! TOML value, and checked by [`numbers`] with its key: a wrong length, a non-number
//! element or a non-array each get an error naming the key.

use std::fmt;

use serde::Deserialize;

use super::ScenarioError;

/// Any TOML value, kept just well enough to check it and to describe it in an error.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum RawValue {
    /// An integer or a float (integers as the nearest f64).
    Number(f64),
    /// An array of values.
    Array(Vec<RawValue>),
    /// Anything else, described for the error (`string "junk"`, `boolean true`, …).
    Other(String),
}

impl fmt::Display for RawValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RawValue::Number(v) => write!(f, "{v}"),
            RawValue::Array(items) => write!(f, "an array of {} elements", items.len()),
            RawValue::Other(what) => f.write_str(what),
        }
    }
}

impl<'de> Deserialize<'de> for RawValue {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(RawValueVisitor)
    }
}

struct RawValueVisitor;

impl<'de> serde::de::Visitor<'de> for RawValueVisitor {
    type Value = RawValue;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("any TOML value")
    }

    fn visit_bool<E>(self, v: bool) -> Result<RawValue, E> {
        Ok(RawValue::Other(format!("boolean {v}")))
    }

    fn visit_i64<E>(self, v: i64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v as f64))
    }

    fn visit_u64<E>(self, v: u64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v as f64))
    }

    fn visit_f64<E>(self, v: f64) -> Result<RawValue, E> {
        Ok(RawValue::Number(v))
    }

    fn visit_str<E>(self, v: &str) -> Result<RawValue, E> {
        Ok(RawValue::Other(format!("string {v:?}")))
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<RawValue, A::Error> {
        let mut items = Vec::new();
        while let Some(item) = seq.next_element()? {
            items.push(item);
        }
        Ok(RawValue::Array(items))
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<RawValue, A::Error> {
        while map
            .next_entry::<serde::de::IgnoredAny, serde::de::IgnoredAny>()?
            .is_some()
        {}
        Ok(RawValue::Other("a table".to_string()))
    }
}

/// The elements of `raw` (at `key`) if it is an array.
pub(super) fn array<'a>(
    key: &str,
    raw: &'a RawValue,
    what: &str,
) -> Result<&'a [RawValue], ScenarioError> {
    match raw {
        RawValue::Array(items) => Ok(items),
        other => Err(ScenarioError::invalid(
            key,
            format!("must be an array of {what}, got {other}"),
        )),
    }
}

/// `raw` (at `key`) as exactly `N` numbers.
pub(super) fn numbers<const N: usize>(
    key: &str,
    raw: &RawValue,
) -> Result<[f64; N], ScenarioError> {
    let items = array(key, raw, &format!("{N} numbers"))?;
    if items.len() != N {
        return Err(ScenarioError::invalid(
            key,
            format!("must have exactly {N} numbers, got {}", items.len()),
        ));
    }
    let mut out = [0.0; N];
    for (i, (o, item)) in out.iter_mut().zip(items).enumerate() {
        match item {
            RawValue::Number(v) => *o = *v,
            other => {
                return Err(ScenarioError::invalid(
                    format!("{key}[{i}]"),
                    format!("must be a number, got {other}"),
                ))
            }
        }
    }
    Ok(out)
}
