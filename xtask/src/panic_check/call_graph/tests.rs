//! The call graph over small hand-assembled images.

use super::*;
use crate::panic_check::panic_names::is_panic_function;
use crate::panic_check::test_support::*;

fn is_panic(f: &Function) -> bool {
    is_panic_function(&f.name)
}

#[test]
fn follows_calls_and_tail_branches_to_the_panic_function() {
    let image = program().image();
    let root = id(&image, "TIM5");
    let found = explore(&image, root, is_panic);

    assert_eq!(
        names(&image, &found.reached),
        [
            "TIM5",
            "leaf",
            "middle",
            "tail",
            "core::panicking::panic_bounds_check"
        ]
    );
    assert_eq!(
        found.panic_sites,
        [PanicSite {
            site: site(id(&image, "tail"), TAIL, EdgeKind::Call),
            callee: id(&image, "core::panicking::panic_bounds_check"),
        }]
    );
    assert_eq!(
        found.problems,
        [],
        "the sink's and the pool's blx are not looked at"
    );

    let chain = found.chain_to(id(&image, "core::panicking::panic_bounds_check"));
    let steps: Vec<_> = chain
        .iter()
        .map(|&(f, via)| {
            (
                image.function(f).name.as_str(),
                via.map(|s| (s.addr, s.kind)),
            )
        })
        .collect();
    assert_eq!(
        steps,
        [
            ("TIM5", None),
            ("middle", Some((ROOT + 6, EdgeKind::Call))),
            ("tail", Some((MIDDLE + 2, EdgeKind::Branch))),
            (
                "core::panicking::panic_bounds_check",
                Some((TAIL, EdgeKind::Call))
            ),
        ]
    );
    assert_eq!(found.chain_to(id(&image, "unreachable")), []);
}

#[test]
fn a_root_without_panic_paths_reaches_only_its_callees() {
    let image = program().image();
    let found = explore(&image, id(&image, "leaf"), is_panic);
    assert_eq!(names(&image, &found.reached), ["leaf"]);
    assert!(found.panic_sites.is_empty());
    assert!(found.problems.is_empty());
}

#[test]
fn reports_every_indirect_call_in_reachable_code() {
    let image = program().image();
    let unreachable = id(&image, "unreachable");
    let found = explore(&image, unreachable, is_panic);
    assert_eq!(
        found.problems,
        [Problem::Indirect {
            function: unreachable,
            addr: UNREACHABLE,
            kind: Indirect::BlxRegister(3),
        }]
    );
    assert_eq!(found.panic_sites.len(), 1);
}

#[test]
fn without_the_data_mapping_the_literal_pool_would_be_taken_for_code() {
    // The same program with middle's `$d` removed: its pool now decodes as an indirect
    // call and a call to `unreachable`, which proves the mapping symbols are what keeps
    // the first test clean.
    let mut asm = program();
    asm.mappings
        .retain(|&(addr, m)| !(addr == MIDDLE + 8 && m == Mapping::Data));
    let image = asm.image();
    let found = explore(&image, id(&image, "TIM5"), is_panic);
    assert!(found.problems.contains(&Problem::Indirect {
        function: id(&image, "middle"),
        addr: MIDDLE + 8,
        kind: Indirect::BlxRegister(3),
    }));
    assert!(found.reached.contains(&id(&image, "unreachable")));
}

#[test]
fn calls_outside_every_function_and_truncated_code_are_problems() {
    let mut asm = Assembler::default();
    let [bl_1, bl_2] = wide_branch(ROOT, BASE + 0x900, true);
    asm.function("root", ROOT, &[bl_1, bl_2, 0xf000]); // ends on a 32-bit first halfword
    let image = asm.image();
    let root = id(&image, "root");
    let found = explore(&image, root, is_panic);
    assert_eq!(
        found.problems,
        [
            Problem::Undecodable {
                function: root,
                addr: ROOT + 4,
                error: DecodeError::Truncated { first: 0xf000 },
            },
            Problem::UnknownTarget {
                function: root,
                addr: ROOT,
                target: BASE + 0x900,
            },
        ]
    );
}

#[test]
fn a_branch_into_the_middle_of_another_function_reaches_that_function() {
    let mut asm = Assembler::default();
    asm.function("shared", LEAF, &[NOP, NOP, BLX_R3, BX_LR]);
    // B (T2) from ROOT to LEAF + 4: offset = LEAF + 4 - (ROOT + 4) = 0x100, imm11 = 0x80.
    let b_n = 0xe000 | 0x80;
    asm.function("root", ROOT, &[b_n]);
    let image = asm.image();
    let found = explore(&image, id(&image, "root"), is_panic);
    assert_eq!(names(&image, &found.reached), ["root", "shared"]);
    assert_eq!(found.problems.len(), 1, "shared is scanned as a whole");
}
