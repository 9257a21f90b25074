//! The functions reachable from a root, by direct calls and by branches that leave the
//! function, found breadth-first (so the chain that first reaches a function is a shortest
//! one), and everything on the way the analysis cannot follow.

use std::collections::{HashMap, VecDeque};

use super::image::{Function, FunctionId, Image, Mapping};
use super::thumb::{self, DecodeError, Flow, Indirect, StackEffect};

/// How a function passes control to another.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeKind {
    /// `BL`.
    Call,
    /// A branch (`B`, `B<c>`, `CBZ`/`CBNZ`) whose target lies in another function: a tail
    /// call, or a jump into shared code.
    Branch,
}

impl EdgeKind {
    /// A short word for reports.
    pub fn verb(self) -> &'static str {
        match self {
            EdgeKind::Call => "bl",
            EdgeKind::Branch => "b",
        }
    }
}

/// An instruction in `caller` that passes control to another function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CallSite {
    /// The function the instruction is in.
    pub caller: FunctionId,
    /// The instruction's address.
    pub addr: u32,
    /// Call or branch.
    pub kind: EdgeKind,
}

/// A call site whose callee is a panic function.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PanicSite {
    /// Where the panic function is called or branched to.
    pub site: CallSite,
    /// The panic function.
    pub callee: FunctionId,
}

/// Something in a reachable function that the analysis cannot vouch for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Problem {
    /// An indirect control transfer that is not a plain return.
    Indirect {
        /// The function it is in.
        function: FunctionId,
        /// The instruction's address.
        addr: u32,
        /// Which transfer.
        kind: Indirect,
    },
    /// Bytes inside a function's Thumb code that are no instruction the decoder vouches for.
    Undecodable {
        /// The function they are in.
        function: FunctionId,
        /// Their address.
        addr: u32,
        /// Why.
        error: DecodeError,
    },
    /// A call or branch to an address that lies in no function symbol.
    UnknownTarget {
        /// The function the instruction is in.
        function: FunctionId,
        /// The instruction's address.
        addr: u32,
        /// The destination.
        target: u32,
    },
    /// Bytes inside a function that no executable section holds, or that the mapping
    /// symbols mark as ARM (A32) code.
    NoThumbCode {
        /// The function.
        function: FunctionId,
        /// The first such address.
        addr: u32,
    },
}

/// Everything reachable from one root.
#[derive(Clone, Debug)]
pub struct Exploration {
    /// The root function.
    pub root: FunctionId,
    /// Every reachable function (root and panic functions included), in the order found.
    pub reached: Vec<FunctionId>,
    /// The call site that first reached each function other than the root.
    first_reached_by: HashMap<FunctionId, CallSite>,
    /// Every call site of a panic function in a reachable function, in the order found.
    pub panic_sites: Vec<PanicSite>,
    /// Every problem in a reachable function, in the order found.
    pub problems: Vec<Problem>,
    /// Each explored function's frame (panic functions are not explored).
    pub frames: HashMap<FunctionId, Frame>,
    /// The functions each explored function calls or branches to, each once.
    pub callees: HashMap<FunctionId, Vec<FunctionId>>,
}

/// What a function's instructions take from the stack, summed over all of them (a
/// function that lowers SP twice is counted twice: an upper bound).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Frame {
    /// Bytes pushed or subtracted from SP by immediates.
    pub bytes: u32,
    /// SP is lowered by a register's value somewhere: the frame's size is unknown.
    pub dynamic: bool,
}

impl Exploration {
    /// The chain from the root to `function`: each function with the call site that
    /// reached it (none for the root), root first. Empty when `function` is unreachable.
    pub fn chain_to(&self, function: FunctionId) -> Vec<(FunctionId, Option<CallSite>)> {
        let mut chain = Vec::new();
        let mut current = function;
        loop {
            if current == self.root {
                chain.push((current, None));
                break;
            }
            let Some(&site) = self.first_reached_by.get(&current) else {
                return Vec::new();
            };
            chain.push((current, Some(site)));
            current = site.caller;
        }
        chain.reverse();
        chain
    }
}

/// Explores everything `root` can reach. Functions for which `is_panic` holds are sinks:
/// they are reached and their call sites recorded, but they are not explored further.
pub fn explore(
    image: &Image,
    root: FunctionId,
    is_panic: impl Fn(&Function) -> bool,
) -> Exploration {
    let mut exploration = Exploration {
        root,
        reached: vec![root],
        first_reached_by: HashMap::new(),
        panic_sites: Vec::new(),
        problems: Vec::new(),
        frames: HashMap::new(),
        callees: HashMap::new(),
    };
    let mut queue = VecDeque::from([root]);
    while let Some(caller) = queue.pop_front() {
        if is_panic(image.function(caller)) {
            continue;
        }
        let (exits, frame) = scan(image, caller, &mut exploration.problems);
        exploration.frames.insert(caller, frame);
        for (site, target) in exits {
            let Some(callee) = image.function_containing(target) else {
                exploration.problems.push(Problem::UnknownTarget {
                    function: caller,
                    addr: site.addr,
                    target,
                });
                continue;
            };
            if is_panic(image.function(callee)) {
                exploration.panic_sites.push(PanicSite { site, callee });
            }
            let callees = exploration.callees.entry(caller).or_default();
            if !callees.contains(&callee) {
                callees.push(callee);
            }
            if callee != root && !exploration.first_reached_by.contains_key(&callee) {
                exploration.first_reached_by.insert(callee, site);
                exploration.reached.push(callee);
                queue.push_back(callee);
            }
        }
    }
    exploration
}

/// Decodes every Thumb instruction of `function` (skipping the data the mapping symbols
/// mark), records its problems, and returns the call sites that leave it with their
/// destinations, and its frame.
fn scan(
    image: &Image,
    function: FunctionId,
    problems: &mut Vec<Problem>,
) -> (Vec<(CallSite, u32)>, Frame) {
    let f = image.function(function);
    let mut exits = Vec::new();
    let mut frame = Frame::default();
    let mut addr = f.addr;
    while addr < f.end() {
        let region_end = image
            .next_mapping_after(addr)
            .map_or(f.end(), |next| next.min(f.end()));
        match image.mapping(addr) {
            Mapping::Data => {
                addr = region_end;
                continue;
            }
            Mapping::Arm => {
                problems.push(Problem::NoThumbCode { function, addr });
                addr = region_end;
                continue;
            }
            Mapping::Thumb => {}
        }
        while addr < region_end {
            let Some(first) = image.halfword(addr) else {
                problems.push(Problem::NoThumbCode { function, addr });
                return (exits, frame);
            };
            let second_addr = addr.wrapping_add(2);
            let second = (second_addr < region_end)
                .then(|| image.halfword(second_addr))
                .flatten();
            match thumb::stack_effect(first, second) {
                StackEffect::Down(bytes) => frame.bytes = frame.bytes.saturating_add(bytes),
                StackEffect::Dynamic => frame.dynamic = true,
                StackEffect::None => {}
            }
            let insn = match thumb::decode(addr, first, second) {
                Ok(insn) => insn,
                Err(error) => {
                    problems.push(Problem::Undecodable {
                        function,
                        addr,
                        error,
                    });
                    // Step over what the first halfword says the length is.
                    addr = addr.wrapping_add(if thumb::is_32bit(first) { 4 } else { 2 });
                    continue;
                }
            };
            match insn.flow {
                Flow::Call { target } => exits.push((site(function, addr, EdgeKind::Call), target)),
                Flow::Branch { target, .. } if !f.contains(target) => {
                    exits.push((site(function, addr, EdgeKind::Branch), target));
                }
                Flow::Indirect(kind) => problems.push(Problem::Indirect {
                    function,
                    addr,
                    kind,
                }),
                Flow::Next
                | Flow::Branch { .. }
                | Flow::TableBranch
                | Flow::Return
                | Flow::Trap => {}
            }
            addr = addr.wrapping_add(insn.len);
        }
    }
    (exits, frame)
}

fn site(caller: FunctionId, addr: u32, kind: EdgeKind) -> CallSite {
    CallSite { caller, addr, kind }
}

#[cfg(test)]
mod tests;
