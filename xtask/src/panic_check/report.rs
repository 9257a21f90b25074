//! The words of the panic check: a one-line verdict per root and, when it fails, every
//! panic path and problem with the chain of calls from the root, one function a line.

use std::fmt::Write as _;

use super::call_graph::{CallSite, Exploration, Problem};
use super::image::{FunctionId, Image};
use super::source_lines::SourceLines;
use super::Root;

/// The findings for one root, ready to print.
pub struct Findings<'a> {
    /// The root.
    pub root: &'a Root,
    /// The image they are in.
    pub image: &'a Image,
    /// What the call graph found.
    pub exploration: Exploration,
    /// Source lines of call sites, when the image has DWARF.
    pub lines: Option<&'a SourceLines<'a>>,
}

impl Findings<'_> {
    /// True when no panic function is reachable and nothing left the analysis.
    pub fn is_clean(&self) -> bool {
        self.exploration.panic_sites.is_empty() && self.exploration.problems.is_empty()
    }

    /// True when some panic site lies in a function named `caller`.
    pub fn has_panic_site_in(&self, caller: &str) -> bool {
        self.exploration
            .panic_sites
            .iter()
            .any(|p| self.image.function(p.site.caller).name == caller)
    }

    /// `control interrupt TIM5 (IRQ 50): 37 functions reachable, no panic path, no
    /// indirect call`, with counts in place of "no" when there are some.
    pub fn verdict(&self) -> String {
        let e = &self.exploration;
        let indirect = e
            .problems
            .iter()
            .filter(|p| matches!(p, Problem::Indirect { .. }))
            .count();
        let other = e.problems.len() - indirect;
        let mut line = format!(
            "{}: {} reachable, {}, {}",
            self.root,
            count(e.reached.len(), "function", "functions"),
            count_or_no(e.panic_sites.len(), "panic path", "panic paths"),
            count_or_no(indirect, "indirect call", "indirect calls"),
        );
        if other > 0 {
            let _ = write!(
                line,
                ", {}",
                count(other, "other problem", "other problems")
            );
        }
        line
    }

    /// Every reachable function, by address, one a line: address, size, name.
    pub fn reachable(&self) -> String {
        let mut ids = self.exploration.reached.clone();
        ids.sort_by_key(|&id| self.image.function(id).addr);
        let mut text = format!("reachable from {}:\n", self.root.name);
        for id in ids {
            let f = self.image.function(id);
            let _ = writeln!(text, "    {:#010x} {:>6} B  {}", f.addr, f.size, f.name);
        }
        text
    }

    /// Each panic path and each problem with the chain that reaches it.
    pub fn details(&self) -> String {
        let e = &self.exploration;
        let mut text = String::new();
        let panics = e.panic_sites.len();
        for (i, panic) in e.panic_sites.iter().enumerate() {
            let callee = &self.image.function(panic.callee).name;
            let _ = writeln!(text, "panic path {} of {panics}: {callee}", i + 1);
            self.write_chain(&mut text, panic.site.caller);
            self.write_step(&mut text, panic.callee, Some(panic.site));
        }
        for problem in &e.problems {
            let (function, addr, what) = describe(self.image, problem);
            let _ = writeln!(text, "{what}");
            self.write_chain(&mut text, function);
            self.write_source(&mut text, addr);
        }
        text
    }

    /// The source lines at `addr`, innermost inlined frame first, one a line.
    fn write_source(&self, text: &mut String, addr: u32) {
        for frame in self.lines.map(|l| l.frames(addr)).unwrap_or_default() {
            let _ = writeln!(
                text,
                "                {}  {}",
                frame.location, frame.function
            );
        }
    }

    /// The chain from the root to `function`, one line each.
    fn write_chain(&self, text: &mut String, function: FunctionId) {
        for (f, via) in self.exploration.chain_to(function) {
            self.write_step(text, f, via);
        }
    }

    /// One function of a chain, and for all but the root the call site that reached it
    /// with its source lines.
    fn write_step(&self, text: &mut String, function: FunctionId, via: Option<CallSite>) {
        let f = self.image.function(function);
        match via {
            None => {
                let _ = writeln!(text, "    {:#010x}  {}", f.addr, f.name);
            }
            Some(site) => {
                let _ = writeln!(
                    text,
                    "    {:#010x}  {}  ({} at {:#010x})",
                    f.addr,
                    f.name,
                    site.kind.verb(),
                    site.addr
                );
                self.write_source(text, site.addr);
            }
        }
    }
}

/// The function a problem is in, the address, and a sentence about it.
fn describe(image: &Image, problem: &Problem) -> (FunctionId, u32, String) {
    let name = |f: FunctionId| &image.function(f).name;
    match *problem {
        Problem::Indirect {
            function,
            addr,
            kind,
        } => (
            function,
            addr,
            format!(
                "indirect call `{kind}` at {addr:#010x} in {}: its target is unknown",
                name(function)
            ),
        ),
        Problem::Undecodable {
            function,
            addr,
            error,
        } => (
            function,
            addr,
            format!(
                "undecodable code at {addr:#010x} in {}: {error}",
                name(function)
            ),
        ),
        Problem::UnknownTarget {
            function,
            addr,
            target,
        } => (
            function,
            addr,
            format!(
                "call or branch at {addr:#010x} in {} to {target:#010x}, which is in no function",
                name(function)
            ),
        ),
        Problem::NoThumbCode { function, addr } => (
            function,
            addr,
            format!(
                "no Thumb code at {addr:#010x} in {} (not in an executable section, or ARM code)",
                name(function)
            ),
        ),
    }
}

/// `1 function`, `3 functions`.
fn count(n: usize, one: &str, many: &str) -> String {
    if n == 1 {
        format!("1 {one}")
    } else {
        format!("{n} {many}")
    }
}

/// `no panic path`, `1 panic path`, `3 panic paths`.
fn count_or_no(n: usize, one: &str, many: &str) -> String {
    if n == 0 {
        format!("no {one}")
    } else {
        count(n, one, many)
    }
}
