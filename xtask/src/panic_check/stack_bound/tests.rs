//! The bound on hand-assembled programs.

use super::*;
use crate::panic_check::call_graph::explore;
use crate::panic_check::test_support::*;

/// `sub sp, #imm7 * 4` (T1).
fn sub_sp(bytes: u16) -> u16 {
    0xb080 | (bytes / 4)
}

/// `root` calls `a` and `b`; `a` calls `c`. Frames: root 8 + 16, a 8 + 400, b 8 + 40,
/// c 8 + 100 (each `push {r7, lr}` is 8 bytes).
fn tree() -> Assembler {
    let (root, a, b, c) = (BASE + 0x100, BASE + 0x200, BASE + 0x300, BASE + 0x400);
    let call = |from: u32, to: u32| wide_branch(from, to, true);
    let mut asm = Assembler::default();
    let [r1, r2] = call(root + 4, a);
    let [r3, r4] = call(root + 8, b);
    asm.function(
        "root",
        root,
        &[PUSH_R7_LR, sub_sp(16), r1, r2, r3, r4, POP_R7_PC],
    );
    let [a1, a2] = call(a + 4, c);
    asm.function("a", a, &[PUSH_R7_LR, sub_sp(400), a1, a2, POP_R7_PC]);
    asm.function("b", b, &[PUSH_R7_LR, sub_sp(40), POP_R7_PC]);
    asm.function("c", c, &[PUSH_R7_LR, sub_sp(100), POP_R7_PC]);
    asm
}

#[test]
fn the_deepest_chain_adds_the_frames_along_it() {
    let image = tree().image();
    let exploration = explore(&image, id(&image, "root"), |_| false);
    let (bytes, chain) = worst_case(&exploration, |_| false).unwrap();
    assert_eq!(bytes, (8 + 16) + (8 + 400) + (8 + 100));
    assert_eq!(names(&image, &chain), ["root", "a", "c"]);
}

#[test]
fn panic_functions_are_not_counted() {
    let image = tree().image();
    let a = id(&image, "a");
    let exploration = explore(&image, id(&image, "root"), |f| f.name == "a");
    let (bytes, chain) = worst_case(&exploration, |f| f == a).unwrap();
    assert_eq!(bytes, (8 + 16) + (8 + 40));
    assert_eq!(names(&image, &chain), ["root", "b"]);
}

#[test]
fn recursion_and_dynamic_frames_have_no_bound() {
    // `root` calls `a`, which calls `root`.
    let (root, a) = (BASE + 0x100, BASE + 0x200);
    let mut asm = Assembler::default();
    let [r1, r2] = wide_branch(root + 2, a, true);
    asm.function("root", root, &[PUSH_R7_LR, r1, r2, POP_R7_PC]);
    let [a1, a2] = wide_branch(a + 2, root, true);
    asm.function("a", a, &[PUSH_R7_LR, a1, a2, POP_R7_PC]);
    let image = asm.image();
    let exploration = explore(&image, id(&image, "root"), |_| false);
    assert_eq!(
        worst_case(&exploration, |_| false),
        Err(Unbounded::Recursion(vec![
            id(&image, "root"),
            id(&image, "a")
        ]))
    );

    // `sub.w sp, sp, r3`.
    let mut asm = Assembler::default();
    asm.function("root", root, &[PUSH_R7_LR, 0xebad, 0x0d03, POP_R7_PC]);
    let image = asm.image();
    let exploration = explore(&image, id(&image, "root"), |_| false);
    assert_eq!(
        worst_case(&exploration, |_| false),
        Err(Unbounded::Dynamic(id(&image, "root")))
    );

    // An indirect call: the analysis cannot follow it.
    let mut asm = Assembler::default();
    asm.function("root", root, &[PUSH_R7_LR, BLX_R3, POP_R7_PC]);
    let image = asm.image();
    let exploration = explore(&image, id(&image, "root"), |_| false);
    assert_eq!(
        worst_case(&exploration, |_| false),
        Err(Unbounded::LeavesAnalysis)
    );
}
