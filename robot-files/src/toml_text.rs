//! TOML text as this crate's files are read: a check of how deeply the text nests, then
//! the `toml` crate's parse.
//!
//! The `toml` reader stops at its own recursion limit, and for a dotted key of 80 parts
//! or more its error is the bare words "recursion limit", with no line and no key. No
//! format here comes near that: the deepest key is 3 parts (`[robot.law.paper]`), the
//! deepest value 2 arrays (`path.waypoints_m`). So the text is first read by the same
//! crate's event parser (`toml_parser`) and refused past [`MAX_NESTING`], with the line
//! and what is too deep; only text within it goes to the `toml` reader, whose other
//! errors name their line themselves.

use serde::de::DeserializeOwned;
use toml_parser::parser::EventReceiver;
use toml_parser::{ErrorSink, Source, Span};

/// Most parts a dotted key may have, and most arrays and inline tables a value may nest
/// inside one another: well above what any format here uses, well below the `toml`
/// reader's own limit of 80.
pub const MAX_NESTING: usize = 16;

/// Key text shown in an error, at most this many characters (then "…").
const KEY_SHOWN_CHARS: usize = 40;

/// Text nested deeper than [`MAX_NESTING`]. Lines count from 1.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NestingError {
    /// A dotted key (in a table header or before `=`) has too many parts.
    #[error(
        "line {line}: the key `{key}` has {parts} parts; a key may have at most {MAX_NESTING}"
    )]
    KeyTooDeep {
        /// Line of the key's first part.
        line: usize,
        /// The key as written, cut to 40 characters.
        key: String,
        /// Its number of parts.
        parts: usize,
    },
    /// Arrays and inline tables nest too deeply.
    #[error(
        "line {line}: arrays and inline tables nest more than {MAX_NESTING} deep; a value \
         may nest at most {MAX_NESTING}"
    )]
    ValueTooDeep {
        /// Line of the opening bracket past the limit.
        line: usize,
    },
}

/// `Err` with the first place where `text` nests deeper than [`MAX_NESTING`]. Syntax
/// errors are left to the `toml` reader: this check only counts.
pub fn check_nesting(text: &str) -> Result<(), NestingError> {
    let tokens = Source::new(text).lex().into_vec();
    let mut check = NestingCheck {
        text,
        depth: 0,
        key: None,
        found: None,
    };
    let mut ignored = ();
    toml_parser::parser::parse_document(&tokens, &mut check, &mut ignored);
    check.end_key();
    check.found.map_or(Ok(()), Err)
}

/// `text` read as a `T`: [`check_nesting`], then the `toml` reader. The error is one
/// message that names the line.
pub(crate) fn from_str<T: DeserializeOwned>(text: &str) -> Result<T, String> {
    check_nesting(text).map_err(|e| e.to_string())?;
    toml::from_str(text).map_err(|e| e.to_string().trim_end().to_string())
}

/// A key being read: where it starts and ends (bytes) and its parts so far.
#[derive(Clone, Copy)]
struct OpenKey {
    start: usize,
    end: usize,
    parts: usize,
}

/// The event receiver that counts: open arrays and inline tables, and the parts of the
/// key being read.
struct NestingCheck<'t> {
    text: &'t str,
    depth: usize,
    key: Option<OpenKey>,
    found: Option<NestingError>,
}

impl NestingCheck<'_> {
    /// Line (from 1) of byte `offset`.
    fn line_of(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        self.text.as_bytes()[..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1
    }

    fn report(&mut self, error: NestingError) {
        if self.found.is_none() {
            self.found = Some(error);
        }
    }

    /// Closes the key being read, if any, and reports it when it has too many parts.
    fn end_key(&mut self) {
        let Some(key) = self.key.take() else {
            return;
        };
        if key.parts > MAX_NESTING {
            let written = self.text.get(key.start..key.end).unwrap_or_default();
            let mut shown: String = written.chars().take(KEY_SHOWN_CHARS).collect();
            if shown.len() < written.len() {
                shown.push('…');
            }
            let line = self.line_of(key.start);
            self.report(NestingError::KeyTooDeep {
                line,
                key: shown,
                parts: key.parts,
            });
        }
    }

    /// One more array or inline table open at `span`: false (do not enter) past the limit.
    fn open(&mut self, span: Span) -> bool {
        self.end_key();
        self.depth += 1;
        if self.depth > MAX_NESTING {
            let line = self.line_of(span.start());
            self.report(NestingError::ValueTooDeep { line });
            return false;
        }
        true
    }

    fn close(&mut self) {
        self.end_key();
        self.depth = self.depth.saturating_sub(1);
    }
}

impl EventReceiver for NestingCheck<'_> {
    fn simple_key(
        &mut self,
        span: Span,
        _kind: Option<toml_parser::decoder::Encoding>,
        _error: &mut dyn ErrorSink,
    ) {
        let key = self.key.get_or_insert(OpenKey {
            start: span.start(),
            end: span.end(),
            parts: 0,
        });
        key.parts += 1;
        key.end = span.end();
    }
    // A dot and the whitespace around it keep the key open; every other event ends it.
    fn key_sep(&mut self, _span: Span, _error: &mut dyn ErrorSink) {}
    fn whitespace(&mut self, _span: Span, _error: &mut dyn ErrorSink) {}
    fn key_val_sep(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
    fn std_table_open(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
    fn std_table_close(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
    fn array_table_open(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
    fn array_table_close(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
    fn inline_table_open(&mut self, span: Span, _error: &mut dyn ErrorSink) -> bool {
        self.open(span)
    }
    fn inline_table_close(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.close();
    }
    fn array_open(&mut self, span: Span, _error: &mut dyn ErrorSink) -> bool {
        self.open(span)
    }
    fn array_close(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.close();
    }
    fn scalar(
        &mut self,
        _span: Span,
        _kind: Option<toml_parser::decoder::Encoding>,
        _error: &mut dyn ErrorSink,
    ) {
        self.end_key();
    }
    fn value_sep(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
    fn comment(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
    fn newline(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
    fn error(&mut self, _span: Span, _error: &mut dyn ErrorSink) {
        self.end_key();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dotted(parts: usize) -> String {
        vec!["a"; parts].join(".")
    }

    #[test]
    fn a_key_with_too_many_parts_is_refused_with_its_line() {
        let text = format!("name = \"x\"\n\n{} = 1\n", dotted(200));
        let e = check_nesting(&text).unwrap_err();
        assert_eq!(
            e,
            NestingError::KeyTooDeep {
                line: 3,
                key: format!("{}…", &dotted(200)[..40]),
                parts: 200,
            }
        );
        assert!(e.to_string().starts_with("line 3: the key `a.a."), "{e}");
        // The same in a table header, with spaces around the dots, and inside an inline
        // table.
        let header = format!("[{}]\nb = 1\n", vec!["a"; 17].join(" . "));
        assert!(matches!(
            check_nesting(&header),
            Err(NestingError::KeyTooDeep {
                line: 1,
                parts: 17,
                ..
            })
        ));
        let inline = format!("x = 1\ny = {{ {} = 1 }}\n", dotted(30));
        assert!(matches!(
            check_nesting(&inline),
            Err(NestingError::KeyTooDeep { line: 2, .. })
        ));
    }

    #[test]
    fn values_nested_too_deeply_are_refused_with_their_line() {
        let text = format!(
            "x = 1\n\ny = {}{}\n",
            "[".repeat(100_000),
            "]".repeat(100_000)
        );
        assert_eq!(
            check_nesting(&text),
            Err(NestingError::ValueTooDeep { line: 3 })
        );
        let tables = format!("y = {}1{}\n", "{a=".repeat(17), "}".repeat(17));
        assert_eq!(
            check_nesting(&tables),
            Err(NestingError::ValueTooDeep { line: 1 })
        );
    }

    #[test]
    fn nesting_up_to_the_limit_is_left_to_the_reader() {
        let at_limit = format!(
            "{} = 1\ny = {}{}\n",
            dotted(MAX_NESTING),
            "[".repeat(MAX_NESTING),
            "]".repeat(MAX_NESTING)
        );
        assert_eq!(check_nesting(&at_limit), Ok(()));
        // A syntax error is not this check's to report.
        assert_eq!(check_nesting("x = = [\n"), Ok(()));
    }
}
