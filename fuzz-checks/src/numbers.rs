//! Whether a value holds a non-finite number anywhere, from its `Debug` form: Rust prints
//! a NaN as `NaN` and an infinity as `inf` or `-inf`, so a scan of the text finds one in
//! any field at any depth, including fields added after this check was written.

use std::fmt::Debug;

/// Panics, naming `what` and the field, when `value`'s `Debug` form holds a NaN or an
/// infinity outside its quoted strings (a name may say "inf" and be no number).
pub fn assert_all_finite(what: &str, value: &impl Debug) {
    let text = format!("{value:?}");
    if let Some(at) = non_finite_at(&text) {
        let from = text[..at].rfind([',', '{', '(']).map_or(0, |i| i + 1);
        let until = text[at..]
            .find([',', '}', ')'])
            .map_or(text.len(), |i| at + i);
        panic!(
            "{what} holds a non-finite number: `{}` in {text}",
            text[from..until].trim()
        );
    }
}

/// The byte offset of the first `NaN`, `inf` or `-inf` token of a `Debug` text, outside
/// double-quoted strings (with their backslash escapes).
fn non_finite_at(text: &str) -> Option<usize> {
    let mut in_string = false;
    let mut escaped = false;
    let mut token_start = None;
    for (i, c) in text.char_indices().chain([(text.len(), ' ')]) {
        if in_string {
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, '\\') => escaped = true,
                (false, '"') => in_string = false,
                _ => {}
            }
            continue;
        }
        if c.is_alphanumeric() || c == '_' || c == '.' {
            token_start.get_or_insert(i);
            continue;
        }
        if let Some(start) = token_start.take() {
            if matches!(&text[start..i], "NaN" | "inf") {
                return Some(start);
            }
        }
        in_string = c == '"';
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug)]
    #[allow(dead_code)]
    struct Sample {
        name: String,
        gain: f32,
        limits: [f64; 2],
        inner: Option<(f32, u8)>,
    }

    fn sample(gain: f32, high: f64, inner: f32) -> Sample {
        Sample {
            name: "inf \"NaN\" inf".to_string(),
            gain,
            limits: [-1.5e30, high],
            inner: Some((inner, 7)),
        }
    }

    #[test]
    fn finite_numbers_and_words_in_strings_pass() {
        assert_eq!(
            non_finite_at(&format!("{:?}", sample(0.5, 2.0, -0.0))),
            None
        );
        assert_eq!(non_finite_at("Info { infinite: 1.0, nan_count: 2 }"), None);
    }

    #[test]
    fn a_nan_or_an_infinity_at_any_depth_is_found() {
        for s in [
            sample(f32::NAN, 1.0, 1.0),
            sample(1.0, f64::INFINITY, 1.0),
            sample(1.0, 1.0, f32::NEG_INFINITY),
        ] {
            let text = format!("{s:?}");
            assert!(non_finite_at(&text).is_some(), "{text}");
        }
    }

    #[test]
    #[should_panic(expected = "a sample holds a non-finite number: `gain: NaN`")]
    fn the_panic_names_the_field() {
        assert_all_finite("a sample", &sample(f32::NAN, 1.0, 1.0));
    }
}
