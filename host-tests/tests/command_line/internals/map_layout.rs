//! `kinecal_cli::formats::map::layout` (cli/src/formats/map/layout.rs) on its own.

use kinecal_cli::formats::map::layout::*;
use kinecal_cli::formats::map::spec::Delimiter;

#[test]
fn delimiters_are_detected() {
    let detect_in = |t: &str, dc: bool| detect(&content_lines(t), dc);
    assert_eq!(
        detect_in("a;b;c\n1,5;2;3\n", true),
        Some(Delimiter::Semicolon)
    );
    // Without decimal commas declared, `;` still wins over the commas inside numbers.
    assert_eq!(
        detect_in("a;b;c\n1,5;2,5;3,5\n", false),
        Some(Delimiter::Semicolon)
    );
    assert_eq!(
        detect_in("# c\na,b,c\n1,2,3\n", false),
        Some(Delimiter::Comma)
    );
    assert_eq!(detect_in("a\tb\n1 2\t3\n", false), Some(Delimiter::Tab));
    assert_eq!(
        detect_in("1  2 3\n4 5   6\n", false),
        Some(Delimiter::Space)
    );
    assert_eq!(detect_in("a,b\n1,2,3\n", false), None);
}

#[test]
fn numbers_with_a_decimal_comma() {
    assert_eq!(number(" -2,6946 ", true), Ok(Some(-2.6946)));
    assert_eq!(number("2,02011E+13", true), Ok(Some(2.02011e13)));
    assert_eq!(number("\"1.5\"", false), Ok(Some(1.5)));
    assert_eq!(number("", true), Ok(None));
    assert_eq!(number("1.000,5", true), Err(NotANumber));
    assert_eq!(number("3,14", false), Err(NotANumber));
}
