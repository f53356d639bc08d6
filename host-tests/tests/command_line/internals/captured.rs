//! `kinecal_cli::captured`: the lines told to `Stderr` kept for the caller (the Python
//! package raises them as warnings), nested captures apart, and the outer one back after a
//! panic inside.

use kinecal_cli::{captured, Stderr, Tell};

#[test]
fn captured_lines_are_kept_in_order_and_nested_captures_apart() {
    let ((), outer) = captured(|| {
        Stderr.line("first");
        let ((), inner) = captured(|| Stderr.line("inner"));
        assert_eq!(inner, ["inner"]);
        Stderr.line("last");
    });
    assert_eq!(outer, ["first", "last"]);
}

#[test]
fn a_panic_inside_a_capture_gives_the_outer_capture_back() {
    let ((), outer) = captured(|| {
        let panicked = std::panic::catch_unwind(|| {
            captured(|| {
                Stderr.line("lost with the panic");
                panic!("inside");
            })
        });
        assert!(panicked.is_err());
        Stderr.line("after");
    });
    assert_eq!(outer, ["after"]);
}
