//! The page's side: what `docs/protocol.md` states, read from its markdown.
//!
//! The page states the protocol in three kinds of block, which this module reads and
//! nothing else:
//!
//! - **a type section**: a heading whose whole text is one code span naming the type
//!   (`` #### `TelemetryFrame` ``), followed by its table. A struct's table starts with
//!   the column `field` (then `type`), an enum's with `index` (then `variant`, `payload`);
//!   further columns are prose. Cells are compared as text with markdown links and
//!   backticks removed and spaces collapsed, so `` [`Pose`](#pose) `` reads `Pose`;
//! - **the constants table**, whose first column is `constant` (then `value`);
//! - **the example frame**: the fenced block after the line [`EXAMPLE_MARKER`], whose
//!   lines `name: hex bytes` give a frame's parts.

use std::collections::BTreeMap;

use anyhow::{bail, Context as _, Result};

use super::schema::{Model, Shape};

/// The line that precedes the example frame's fenced block.
pub const EXAMPLE_MARKER: &str = "<!-- example frame: checked by cargo xtask ci -->";

/// What the page states.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Page {
    /// Every type section, as a model (enum rows in the page's order).
    pub model: Model,
    /// The index each enum row states, by type, in the page's row order.
    pub stated_indices: BTreeMap<String, Vec<String>>,
    /// The constants table: name and value as written.
    pub constants: Vec<(String, String)>,
    /// The example frame's lines: part name and its bytes.
    pub example: Vec<(String, Vec<u8>)>,
}

/// A cell as text: links reduced to their text, backticks removed, spaces collapsed.
pub fn cell_text(cell: &str) -> String {
    let mut out = String::new();
    let mut rest = cell;
    while let Some(open) = rest.find('[') {
        let after = &rest[open + 1..];
        match after.find("](") {
            Some(mid) if !after[..mid].contains('[') => {
                let target = &after[mid + 2..];
                match target.find(')') {
                    Some(close) => {
                        out.push_str(&rest[..open]);
                        out.push_str(&after[..mid]);
                        rest = &target[close + 1..];
                    }
                    None => break,
                }
            }
            _ => {
                out.push_str(&rest[..open + 1]);
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out.replace('`', "")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// The cells of a table row.
fn cells(line: &str) -> Vec<String> {
    let inner = line.trim().trim_start_matches('|').trim_end_matches('|');
    inner.split('|').map(cell_text).collect()
}

/// The type a heading names: its whole text is one code span holding an identifier.
fn heading_type(line: &str) -> Option<String> {
    let text = line.trim_start_matches('#').trim();
    let name = text.strip_prefix('`')?.strip_suffix('`')?;
    (!name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
        .then(|| name.to_string())
}

/// Reads the page.
pub fn parse(text: &str) -> Result<Page> {
    let mut page = Page::default();
    let lines: Vec<&str> = text.lines().collect();
    let mut section: Option<String> = None;
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        let number = i + 1;
        if line.starts_with('#') {
            section = heading_type(line);
            i += 1;
            continue;
        }
        if line.trim() == EXAMPLE_MARKER {
            i = read_example(&lines, i + 1, &mut page)?;
            continue;
        }
        if !line.trim_start().starts_with('|') {
            i += 1;
            continue;
        }
        // A table: its header, the separator, the rows.
        let header = cells(line);
        let end = (i..lines.len())
            .find(|&j| !lines[j].trim_start().starts_with('|'))
            .unwrap_or(lines.len());
        let rows: Vec<(usize, Vec<String>)> =
            (i + 2..end).map(|j| (j + 1, cells(lines[j]))).collect();
        let first = header.first().map(String::as_str).unwrap_or("");
        match (first, section.take()) {
            ("constant", _) => {
                for (n, row) in rows {
                    let [name, value, ..] = row.as_slice() else {
                        bail!("line {n}: a constant needs a name and a value");
                    };
                    page.constants.push((name.clone(), value.clone()));
                }
            }
            ("field", Some(name)) => {
                let fields = rows
                    .into_iter()
                    .map(|(n, row)| match row.as_slice() {
                        [field, ty, ..] => Ok((field.clone(), ty.clone())),
                        _ => bail!("line {n}: a field row needs a name and a type"),
                    })
                    .collect::<Result<Vec<_>>>()?;
                insert(&mut page, name, Shape::Struct(fields), number)?;
            }
            ("index", Some(name)) => {
                let mut indices = Vec::new();
                let variants = rows
                    .into_iter()
                    .map(|(n, row)| match row.as_slice() {
                        [index, variant, payload, ..] => {
                            indices.push(index.clone());
                            Ok((variant.clone(), payload.clone()))
                        }
                        _ => bail!("line {n}: a variant row needs an index, a name and a payload"),
                    })
                    .collect::<Result<Vec<_>>>()?;
                page.stated_indices.insert(name.clone(), indices);
                insert(&mut page, name, Shape::Enum(variants), number)?;
            }
            (other, Some(name)) => bail!(
                "line {number}: the table of `{name}` must start with the column `field` (a \
                 struct) or `index` (an enum), not `{other}`"
            ),
            (_, None) => {}
        }
        i = end;
    }
    Ok(page)
}

fn insert(page: &mut Page, name: String, shape: Shape, line: usize) -> Result<()> {
    if page.model.types.contains_key(&name) {
        bail!("line {line}: `{name}` has a second section");
    }
    page.model.order.push(name.clone());
    page.model.types.insert(name, shape);
    Ok(())
}

/// Reads the fenced block starting at or after line index `from`; returns the index after it.
fn read_example(lines: &[&str], from: usize, page: &mut Page) -> Result<usize> {
    let open = (from..lines.len())
        .find(|&j| lines[j].trim_start().starts_with("```"))
        .context("the example frame's marker is not followed by a fenced block")?;
    let mut j = open + 1;
    while j < lines.len() && !lines[j].trim_start().starts_with("```") {
        let line = lines[j];
        if let Some((name, bytes)) = line.split_once(':') {
            let bytes = bytes
                .split_whitespace()
                .map(|b| {
                    u8::from_str_radix(b, 16)
                        .with_context(|| format!("line {}: `{b}` is not a hex byte", j + 1))
                })
                .collect::<Result<Vec<_>>>()?;
            page.example.push((name.trim().to_string(), bytes));
        }
        j += 1;
    }
    Ok(j + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_reads_as_its_text() {
        assert_eq!(cell_text(" [`Pose`](#pose) "), "Pose");
        assert_eq!(
            cell_text("`Option<`[`BodyVelocity`](#bodyvelocity)`>`"),
            "Option<BodyVelocity>"
        );
        assert_eq!(
            cell_text("`{ mode:` [`ArmMode`](#armmode)`,  hz: u8 }`"),
            "{ mode: ArmMode, hz: u8 }"
        );
        assert_eq!(cell_text("a [b] c"), "a [b] c");
    }

    const PAGE: &str = "\
# The protocol

| constant | value | meaning |
|---|---|---|
| `SCHEMA_HASH` | `0x12345678` | the hash |

#### `Ping`

| field | type | meaning |
|---|---|---|
| `nonce` | `u32` | any value |

Prose.

#### `Request`

| index | variant | payload | meaning |
|---|---|---|---|
| 0 | `Info` | — | who |
| 1 | `Ping` | [`Ping`](#ping) | echo |

<!-- example frame: checked by cargo xtask ci -->

```text
body:    01 ac 02
frame:   03 01 ac 02 00
```
";

    #[test]
    fn the_page_gives_its_types_constants_and_example() {
        let page = parse(PAGE).unwrap();
        assert_eq!(page.model.order, ["Ping", "Request"]);
        assert_eq!(
            page.model.types["Request"],
            Shape::Enum(vec![
                ("Info".into(), "—".into()),
                ("Ping".into(), "Ping".into())
            ])
        );
        assert_eq!(page.stated_indices["Request"], ["0", "1"]);
        assert_eq!(
            page.constants,
            [("SCHEMA_HASH".to_string(), "0x12345678".to_string())]
        );
        assert_eq!(page.example[0], ("body".to_string(), vec![1, 0xac, 2]));
    }

    #[test]
    fn a_type_table_of_another_kind_is_named() {
        let bad = "#### `Ping`\n\n| name | type |\n|---|---|\n| `a` | `u8` |\n";
        let e = parse(bad).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("`Ping`"), "{e}");
    }
}
