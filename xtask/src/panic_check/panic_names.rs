//! Which functions count as panics, by their demangled names (hash dropped, as
//! [`super::image::demangle`] gives them).
//!
//! The names only make the report end at a recognisable function (`panic_bounds_check`
//! rather than the formatting machinery behind it). They are not what makes the check
//! sound: the call graph goes on through every function that is not named here, so any
//! chain that ends in the panic handler ends at [`is_panic_handler`] at the latest,
//! whatever it passes through.

/// True for the `#[panic_handler]`: rustc exports it as `rust_begin_unwind`, mangled as
/// `__rustc::rust_begin_unwind` by recent compilers.
pub fn is_panic_handler(name: &str) -> bool {
    name == "rust_begin_unwind" || name.ends_with("::rust_begin_unwind")
}

/// Functions of `core` that exist only to panic, by prefix: `core::panicking::panic`,
/// `panic_fmt`, `panic_bounds_check`, `panic_const::panic_const_rem_by_zero`,
/// `panic_nounwind`, `assert_failed`, …
const PREFIXES: [&str; 1] = ["core::panicking::"];

/// Functions of `core` that exist only to panic, by full name.
const NAMES: [&str; 7] = [
    "core::option::unwrap_failed",
    "core::option::expect_failed",
    "core::result::unwrap_failed",
    "core::str::slice_error_fail",
    "core::str::slice_error_fail_rt",
    "core::cell::panic_already_borrowed",
    "core::cell::panic_already_mutably_borrowed",
];

/// True for a function that only leads to the panic handler: the handler itself, the
/// `core` functions above, and the slice indexing failures
/// (`core::slice::index::slice_end_index_len_fail`, …).
pub fn is_panic_function(name: &str) -> bool {
    is_panic_handler(name)
        || PREFIXES.iter().any(|prefix| name.starts_with(prefix))
        || NAMES.contains(&name)
        || (name.starts_with("core::slice::index::") && name.contains("fail"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn panic_functions_by_name() {
        for name in [
            "core::panicking::panic_bounds_check",
            "core::panicking::panic_fmt",
            "core::panicking::panic_const::panic_const_rem_by_zero",
            "core::panicking::panic_nounwind",
            "core::panicking::assert_failed::<u32, u32>",
            "core::option::unwrap_failed",
            "core::result::unwrap_failed",
            "core::slice::index::slice_end_index_len_fail",
            "core::slice::index::slice_index_order_fail",
            "core::str::slice_error_fail",
            "__rustc::rust_begin_unwind",
            "rust_begin_unwind",
        ] {
            assert!(is_panic_function(name), "{name}");
        }
    }

    #[test]
    fn neighbours_that_do_not_panic() {
        for name in [
            "core::panic::panic_info::PanicMessage::as_str",
            "core::slice::index::range",
            "core::option::Option::unwrap_or",
            "core::fmt::Formatter::pad_integral",
            "controller_core::panicking_helper",
            "firmware::app::control",
            "__aeabi_memcpy",
        ] {
            assert!(!is_panic_function(name), "{name}");
        }
        assert!(!is_panic_handler("my_rust_begin_unwind"));
    }
}
