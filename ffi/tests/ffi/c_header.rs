//! `include/kinecal.h` is what cbindgen makes of this crate now: fails with a message when it
//! is stale; `KINECAL_BLESS=1` rewrites it.

use std::path::PathBuf;

#[test]
fn header_is_current() {
    let crate_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(crate_dir.join("cbindgen.toml"))
        .expect("ffi/cbindgen.toml parses");
    let bindings = cbindgen::Builder::new()
        .with_crate(&crate_dir)
        .with_config(config)
        .generate()
        .expect("cbindgen generates the header");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    // Rustdoc's link brackets (`[`kc_fk_point`]`) read as plain code names in C comments.
    let generated = String::from_utf8(generated)
        .expect("the header is UTF-8")
        .replace("[`", "`")
        .replace("`]", "`");
    let path = crate_dir.join("../include/kinecal.h");
    let current = std::fs::read_to_string(&path).unwrap_or_default();
    if current == generated {
        return;
    }
    if std::env::var_os("KINECAL_BLESS").is_some_and(|v| v == "1") {
        std::fs::write(&path, generated).expect("include/kinecal.h is writable");
        return;
    }
    panic!(
        "include/kinecal.h is stale: run KINECAL_BLESS=1 cargo test -p kinecal-ffi --test ffi c_header"
    );
}
