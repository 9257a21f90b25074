//! The worst-case stack of an interrupt handler, from the call graph the panic check
//! builds: each function's frame (what its instructions push or subtract from SP,
//! [`Frame`]) plus the deepest of its callees', along the deepest chain. A bound, not a
//! measurement: it holds whatever the timing, as long as the chain has no recursion,
//! no frame of dynamic size and no transfer the analysis cannot follow (each of those
//! makes the bound unknown, and says why).
//!
//! Panic functions are not followed: what runs after a panic is the panic handler's
//! business (it stops the motors and halts).

use std::collections::HashMap;

use super::call_graph::{Exploration, Frame};
use super::image::FunctionId;

/// Why a handler's stack has no bound.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Unbounded {
    /// A function lowers SP by a register's value.
    Dynamic(FunctionId),
    /// The chain calls back into itself (the functions of the cycle, in order).
    Recursion(Vec<FunctionId>),
    /// The exploration met a transfer it cannot follow, or code it cannot decode.
    LeavesAnalysis,
}

/// The deepest chain from the exploration's root: its bytes and its functions, root
/// first.
pub fn worst_case(
    exploration: &Exploration,
    is_panic: impl Fn(FunctionId) -> bool,
) -> Result<(u32, Vec<FunctionId>), Unbounded> {
    if !exploration.problems.is_empty() {
        return Err(Unbounded::LeavesAnalysis);
    }
    let mut search = Search {
        exploration,
        is_panic: &is_panic,
        done: HashMap::new(),
        path: Vec::new(),
    };
    let bytes = search.deepest(exploration.root)?;
    let mut chain = vec![exploration.root];
    while let Some(&Some(next)) = chain
        .last()
        .and_then(|f| search.done.get(f))
        .map(|(_, n)| n)
    {
        chain.push(next);
    }
    Ok((bytes, chain))
}

struct Search<'a, P> {
    exploration: &'a Exploration,
    is_panic: &'a P,
    /// Finished functions: their depth and the callee of their deepest chain.
    done: HashMap<FunctionId, (u32, Option<FunctionId>)>,
    /// The functions being explored, outermost first (a cycle shows up here).
    path: Vec<FunctionId>,
}

impl<P: Fn(FunctionId) -> bool> Search<'_, P> {
    fn deepest(&mut self, function: FunctionId) -> Result<u32, Unbounded> {
        if let Some(&(bytes, _)) = self.done.get(&function) {
            return Ok(bytes);
        }
        if let Some(at) = self.path.iter().position(|&f| f == function) {
            return Err(Unbounded::Recursion(self.path[at..].to_vec()));
        }
        let frame: Frame = self
            .exploration
            .frames
            .get(&function)
            .copied()
            .unwrap_or_default();
        if frame.dynamic {
            return Err(Unbounded::Dynamic(function));
        }
        self.path.push(function);
        let mut deepest: (u32, Option<FunctionId>) = (0, None);
        let callees = self
            .exploration
            .callees
            .get(&function)
            .cloned()
            .unwrap_or_default();
        for callee in callees {
            if (self.is_panic)(callee) {
                continue;
            }
            let bytes = self.deepest(callee)?;
            if bytes > deepest.0 || deepest.1.is_none() {
                deepest = (bytes, Some(callee));
            }
        }
        self.path.pop();
        let total = frame.bytes.saturating_add(deepest.0);
        self.done.insert(function, (total, deepest.1));
        Ok(total)
    }
}

#[cfg(test)]
mod tests;
