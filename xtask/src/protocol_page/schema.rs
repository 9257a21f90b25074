//! The build's side: every type the link's two message enums carry, described in the
//! page's notation, walked from their postcard-schema `SCHEMA`.
//!
//! The notation is the one `docs/protocol.md` uses in its tables: `u8` … `u64`, `i16` …
//! `i64`, `f32`, `f64`, `bool`, `String` (a length-prefixed UTF-8 string), `Vec<T>` (a
//! length-prefixed sequence), `Option<T>`, `Result<T, E>`, a struct or enum by its name,
//! and for a struct variant its fields as `{ name: T, … }`.

use std::collections::BTreeMap;

use anyhow::{bail, Result};
use postcard_schema::schema::{DataModelType, DataModelVariant, NamedType, NamedValue};

/// One named type of the protocol: its fields or its variants, in wire order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Shape {
    /// A struct: `(field name, type)` in order.
    Struct(Vec<(String, String)>),
    /// An enum: `(variant name, payload)`, the variant's index being its position; the
    /// payload is `—` for a unit variant.
    Enum(Vec<(String, String)>),
}

impl Shape {
    /// `struct` or `enum`.
    pub fn kind(&self) -> &'static str {
        match self {
            Shape::Struct(_) => "struct",
            Shape::Enum(_) => "enum",
        }
    }
}

/// The payload of a unit variant, in the notation.
pub const UNIT: &str = "—";

/// Every named type reachable from some roots, by name, and the order they were first
/// met in (roots first, then breadth first).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Model {
    /// Each type's shape, by name.
    pub types: BTreeMap<String, Shape>,
    /// The names in the order they were met.
    pub order: Vec<String>,
}

impl Model {
    /// The model of everything `roots` carry.
    pub fn of(roots: &[&'static NamedType]) -> Result<Model> {
        let mut model = Model::default();
        let mut queue: Vec<&'static NamedType> = roots.to_vec();
        let mut next = 0;
        while let Some(&ty) = queue.get(next) {
            next += 1;
            let Some(shape) = shape_of(ty, &mut queue)? else {
                continue;
            };
            match model.types.get(ty.name) {
                Some(known) if *known == shape => {}
                Some(_) => bail!(
                    "two different types are named `{}`: the page could not tell them apart; \
                     rename one",
                    ty.name
                ),
                None => {
                    model.order.push(ty.name.to_string());
                    model.types.insert(ty.name.to_string(), shape);
                }
            }
        }
        Ok(model)
    }
}

/// The shape of `ty` if it is a named struct or enum of its own (`None` for primitives and
/// the generic wrappers), queueing the types it carries.
fn shape_of(ty: &'static NamedType, queue: &mut Vec<&'static NamedType>) -> Result<Option<Shape>> {
    if is_result(ty) {
        queue.extend(result_sides(ty));
        return Ok(None);
    }
    match ty.ty {
        DataModelType::Struct(fields) => Ok(Some(Shape::Struct(
            fields
                .iter()
                .map(|f| {
                    queue.push(f.ty);
                    Ok((f.name.to_string(), notation(f.ty)?))
                })
                .collect::<Result<_>>()?,
        ))),
        DataModelType::Enum(variants) => Ok(Some(Shape::Enum(
            variants
                .iter()
                .map(|v| Ok((v.name.to_string(), payload(v.ty, queue)?)))
                .collect::<Result<_>>()?,
        ))),
        DataModelType::Option(inner) | DataModelType::Seq(inner) => {
            queue.push(inner);
            Ok(None)
        }
        DataModelType::Tuple(items) => {
            queue.extend(items.iter().copied());
            Ok(None)
        }
        _ => {
            // Primitives have no section; anything else the notation cannot say.
            notation(ty)?;
            Ok(None)
        }
    }
}

/// A variant's payload in the notation, queueing the types it carries.
fn payload(
    variant: &'static DataModelVariant,
    queue: &mut Vec<&'static NamedType>,
) -> Result<String> {
    match variant {
        DataModelVariant::UnitVariant => Ok(UNIT.to_string()),
        DataModelVariant::NewtypeVariant(ty) => {
            queue.push(ty);
            notation(ty)
        }
        DataModelVariant::TupleVariant(items) => {
            queue.extend(items.iter().copied());
            tuple(items)
        }
        DataModelVariant::StructVariant(fields) => {
            queue.extend(fields.iter().map(|f| f.ty));
            struct_fields(fields)
        }
    }
}

/// `{ a: T, b: U }`.
fn struct_fields(fields: &[&NamedValue]) -> Result<String> {
    let fields = fields
        .iter()
        .map(|f| Ok(format!("{}: {}", f.name, notation(f.ty)?)))
        .collect::<Result<Vec<_>>>()?;
    Ok(format!("{{ {} }}", fields.join(", ")))
}

/// `(T, U)`, or `T` for a one-element tuple (which postcard writes as the element alone).
fn tuple(items: &[&NamedType]) -> Result<String> {
    let items = items
        .iter()
        .map(|t| notation(t))
        .collect::<Result<Vec<_>>>()?;
    Ok(match items.as_slice() {
        [one] => one.clone(),
        _ => format!("({})", items.join(", ")),
    })
}

/// True for `core::result::Result`, which the notation writes as `Result<T, E>`.
fn is_result(ty: &NamedType) -> bool {
    ty.name == "Result<T, E>" && result_sides(ty).len() == 2
}

/// The `Ok` and `Err` types of a `Result`.
fn result_sides(ty: &NamedType) -> Vec<&'static NamedType> {
    let DataModelType::Enum(variants) = ty.ty else {
        return Vec::new();
    };
    variants
        .iter()
        .filter_map(|v| match v.ty {
            DataModelVariant::NewtypeVariant(t) => Some(*t),
            DataModelVariant::TupleVariant([t]) => Some(*t),
            _ => None,
        })
        .collect()
}

/// `ty` in the page's notation.
pub fn notation(ty: &NamedType) -> Result<String> {
    if is_result(ty) {
        let sides = result_sides(ty);
        return Ok(format!(
            "Result<{}, {}>",
            notation(sides[0])?,
            notation(sides[1])?
        ));
    }
    Ok(match ty.ty {
        DataModelType::Bool => "bool".into(),
        DataModelType::I8 => "i8".into(),
        DataModelType::U8 => "u8".into(),
        DataModelType::I16 => "i16".into(),
        DataModelType::I32 => "i32".into(),
        DataModelType::I64 => "i64".into(),
        DataModelType::U16 => "u16".into(),
        DataModelType::U32 => "u32".into(),
        DataModelType::U64 => "u64".into(),
        DataModelType::F32 => "f32".into(),
        DataModelType::F64 => "f64".into(),
        DataModelType::String => "String".into(),
        DataModelType::Option(inner) => format!("Option<{}>", notation(inner)?),
        DataModelType::Seq(inner) => format!("Vec<{}>", notation(inner)?),
        DataModelType::Tuple(items) => tuple(items)?,
        DataModelType::Struct(_) | DataModelType::Enum(_) => ty.name.to_string(),
        other => bail!(
            "`{}` is encoded as {other:?}, which docs/protocol.md's notation has no word for \
             (extend the page's encoding rules and this check)",
            ty.name
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use postcard_schema::Schema;

    #[allow(dead_code)]
    #[derive(Schema)]
    struct Inner {
        a: u16,
        b: Option<f32>,
    }

    #[allow(dead_code)]
    #[derive(Schema)]
    enum Message {
        Ping { nonce: u32 },
        Wrapped(Inner),
        Stop,
        Answer(Result<Inner, u8>),
        Many(heapless::Vec<i32, 4>),
    }

    #[test]
    fn a_model_names_every_type_with_its_wire_shape_in_order() {
        let model = Model::of(&[Message::SCHEMA]).unwrap();
        assert_eq!(model.order, ["Message", "Inner"]);
        assert_eq!(
            model.types["Message"],
            Shape::Enum(vec![
                ("Ping".into(), "{ nonce: u32 }".into()),
                ("Wrapped".into(), "Inner".into()),
                ("Stop".into(), UNIT.into()),
                ("Answer".into(), "Result<Inner, u8>".into()),
                ("Many".into(), "Vec<i32>".into()),
            ])
        );
        assert_eq!(
            model.types["Inner"],
            Shape::Struct(vec![
                ("a".into(), "u16".into()),
                ("b".into(), "Option<f32>".into())
            ])
        );
    }

    #[test]
    fn the_links_messages_are_all_describable() {
        let model = Model::of(&[link::Downlink::SCHEMA, link::Uplink::SCHEMA]).unwrap();
        for name in [
            "Request",
            "Reply",
            "Uplink",
            "TelemetryFrame",
            "Faults",
            "TuneResult",
        ] {
            assert!(model.types.contains_key(name), "{name} missing");
        }
    }
}
