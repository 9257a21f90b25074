//! What differs between the build and the page, each difference as one sentence that
//! names the type, the field or variant, and what to write.

use super::page::Page;
use super::schema::{Model, Shape};

/// Every difference between the build's `build` and the `page`, in the build's order of
/// types, then the page's extra types.
pub fn differences(build: &Model, page: &Page) -> Vec<String> {
    let mut out = Vec::new();
    for name in &build.order {
        let ours = &build.types[name];
        match page.model.types.get(name) {
            None => out.push(format!(
                "`{name}` ({}) is in the build but has no section on the page; add:\n\n{}",
                ours.kind(),
                section(name, ours)
            )),
            Some(theirs) => out.extend(shape_differences(name, ours, theirs, page)),
        }
    }
    for name in &page.model.order {
        if !build.types.contains_key(name) {
            out.push(format!(
                "`{name}` has a section on the page, but no message of the build carries it \
                 (renamed or removed?)"
            ));
        }
    }
    out
}

fn shape_differences(name: &str, ours: &Shape, theirs: &Shape, page: &Page) -> Vec<String> {
    match (ours, theirs) {
        (Shape::Struct(a), Shape::Struct(b)) => list_differences(name, "field", a, b),
        (Shape::Enum(a), Shape::Enum(b)) => {
            let mut out = list_differences(name, "variant", a, b);
            let stated = page.stated_indices.get(name).cloned().unwrap_or_default();
            for (position, ((variant, _), index)) in b.iter().zip(&stated).enumerate() {
                if index.trim() != position.to_string() {
                    out.push(format!(
                        "`{name}`: the row of `{variant}` states index {index}, but it is row \
                         {position} (a variant's index is its position)"
                    ));
                }
            }
            out
        }
        _ => vec![format!(
            "`{name}` is {} {} in the build, {} {} on the page",
            article(ours.kind()),
            ours.kind(),
            article(theirs.kind()),
            theirs.kind()
        )],
    }
}

fn article(kind: &str) -> &'static str {
    if kind == "enum" {
        "an"
    } else {
        "a"
    }
}

/// The differences of two lists of `(name, type)`: missing and extra entries, order, types.
fn list_differences(
    owner: &str,
    what: &str,
    build: &[(String, String)],
    page: &[(String, String)],
) -> Vec<String> {
    let mut out = Vec::new();
    let find = |list: &[(String, String)], name: &str| list.iter().position(|(n, _)| n == name);
    for (position, (name, ty)) in build.iter().enumerate() {
        if find(page, name).is_none() {
            let row = if what == "variant" {
                enum_row(position, name, ty)
            } else {
                struct_row(name, ty)
            };
            out.push(format!(
                "`{owner}`: the {what} `{name}` ({}, `{ty}`) is in the build but not on the \
                 page; add the row\n    {row}",
                if what == "variant" {
                    format!("index {position}")
                } else {
                    format!("field {position}")
                }
            ));
        }
    }
    for (name, _) in page {
        if find(build, name).is_none() {
            out.push(format!(
                "`{owner}`: the page lists the {what} `{name}`, which the build does not have"
            ));
        }
    }
    let common = |a: &[(String, String)], b: &[(String, String)]| -> Vec<String> {
        a.iter()
            .filter(|(n, _)| find(b, n).is_some())
            .map(|(n, _)| n.clone())
            .collect()
    };
    let (ours, theirs) = (common(build, page), common(page, build));
    if ours != theirs {
        out.push(format!(
            "`{owner}`: the page orders its {what}s `{}`, the build (the wire order) `{}`",
            theirs.join(", "),
            ours.join(", ")
        ));
    }
    for (name, ty) in build {
        if let Some(i) = find(page, name) {
            if page[i].1 != *ty {
                out.push(format!(
                    "`{owner}.{name}`: the page says `{}`, the build has `{ty}`",
                    page[i].1
                ));
            }
        }
    }
    out
}

/// A type as a table cell: a link to its section when it is one named type.
fn type_cell(ty: &str) -> String {
    let named = ty.chars().next().is_some_and(|c| c.is_ascii_uppercase())
        && ty.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && ty != "String";
    if named {
        format!("[`{ty}`](#{})", ty.to_ascii_lowercase())
    } else if ty == super::schema::UNIT {
        ty.to_string()
    } else {
        format!("`{ty}`")
    }
}

fn struct_row(name: &str, ty: &str) -> String {
    format!("| `{name}` | {} | … |", type_cell(ty))
}

fn enum_row(index: usize, name: &str, payload: &str) -> String {
    format!("| {index} | `{name}` | {} | … |", type_cell(payload))
}

/// A whole section for `name`, ready to paste (the prose column left to write).
pub fn section(name: &str, shape: &Shape) -> String {
    let mut out = format!("#### `{name}`\n\n");
    match shape {
        Shape::Struct(fields) => {
            out.push_str("| field | type | meaning |\n|---|---|---|\n");
            for (field, ty) in fields {
                out.push_str(&struct_row(field, ty));
                out.push('\n');
            }
        }
        Shape::Enum(variants) => {
            out.push_str("| index | variant | payload | meaning |\n|---|---|---|---|\n");
            for (i, (variant, payload)) in variants.iter().enumerate() {
                out.push_str(&enum_row(i, variant, payload));
                out.push('\n');
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol_page::page::parse;

    fn model(types: &[(&str, Shape)]) -> Model {
        Model {
            order: types.iter().map(|(n, _)| n.to_string()).collect(),
            types: types
                .iter()
                .map(|(n, s)| (n.to_string(), s.clone()))
                .collect(),
        }
    }

    fn pairs(items: &[(&str, &str)]) -> Vec<(String, String)> {
        items
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    }

    const PAGE: &str = "\
#### `Request`

| index | variant | payload | meaning |
|---|---|---|---|
| 0 | `Info` | — | who |
| 1 | `Ping` | `{ nonce: u32 }` | echo |

#### `Pose`

| field | type | meaning |
|---|---|---|
| `x_m` | `f32` | m |
| `y_m` | `f32` | m |
";

    fn build() -> Model {
        model(&[
            (
                "Request",
                Shape::Enum(pairs(&[("Info", "—"), ("Ping", "{ nonce: u32 }")])),
            ),
            (
                "Pose",
                Shape::Struct(pairs(&[("x_m", "f32"), ("y_m", "f32")])),
            ),
        ])
    }

    #[test]
    fn a_page_that_states_the_build_has_no_difference() {
        assert_eq!(
            differences(&build(), &parse(PAGE).unwrap()),
            Vec::<String>::new()
        );
    }

    #[test]
    fn a_new_variant_is_named_with_its_index_and_the_row_to_add() {
        let mut build = build();
        build.types.insert(
            "Request".into(),
            Shape::Enum(pairs(&[
                ("Info", "—"),
                ("Ping", "{ nonce: u32 }"),
                ("SetPose", "Pose"),
            ])),
        );
        let found = differences(&build, &parse(PAGE).unwrap());
        assert_eq!(found.len(), 1, "{found:#?}");
        assert!(
            found[0].starts_with("`Request`: the variant `SetPose` (index 2, `Pose`)"),
            "{}",
            found[0]
        );
        assert!(
            found[0].ends_with("| 2 | `SetPose` | [`Pose`](#pose) | … |"),
            "{}",
            found[0]
        );
    }

    #[test]
    fn a_new_type_gets_its_whole_section() {
        let mut build = build();
        build.order.push("Point".into());
        build
            .types
            .insert("Point".into(), Shape::Struct(pairs(&[("x_m", "f32")])));
        let found = differences(&build, &parse(PAGE).unwrap());
        assert_eq!(found.len(), 1, "{found:#?}");
        assert!(found[0].contains("#### `Point`"), "{}", found[0]);
        assert!(found[0].contains("| `x_m` | `f32` | … |"), "{}", found[0]);
    }

    #[test]
    fn a_wrong_type_an_extra_field_a_wrong_order_and_a_wrong_index_are_each_named() {
        let page = PAGE
            .replace(
                "| `y_m` | `f32` | m |",
                "| `y_m` | `u16` | m |\n| `z_m` | `f32` | m |",
            )
            .replace("| 1 | `Ping`", "| 7 | `Ping`");
        let found = differences(&build(), &parse(&page).unwrap());
        assert!(
            found
                .iter()
                .any(|d| d == "`Pose.y_m`: the page says `u16`, the build has `f32`"),
            "{found:#?}"
        );
        assert!(
            found
                .iter()
                .any(|d| d.contains("`Pose`: the page lists the field `z_m`")),
            "{found:#?}"
        );
        assert!(
            found
                .iter()
                .any(|d| d.contains("states index 7, but it is row 1")),
            "{found:#?}"
        );
        let swapped = PAGE.replace(
            "| `x_m` | `f32` | m |\n| `y_m` | `f32` | m |",
            "| `y_m` | `f32` | m |\n| `x_m` | `f32` | m |",
        );
        let found = differences(&build(), &parse(&swapped).unwrap());
        assert_eq!(
            found,
            ["`Pose`: the page orders its fields `y_m, x_m`, the build (the wire order) `x_m, y_m`"]
        );
    }

    #[test]
    fn a_type_no_message_carries_is_named() {
        let mut build = build();
        build.order.retain(|n| n != "Pose");
        build.types.remove("Pose");
        let found = differences(&build, &parse(PAGE).unwrap());
        assert_eq!(found.len(), 1);
        assert!(found[0].starts_with("`Pose` has a section on the page, but no message"));
    }
}
