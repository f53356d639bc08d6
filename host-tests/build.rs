//! Compiles the C host test of the C ABI (`ffi/tests/c/host_test.c` with its CSV part
//! `csv_test.c`, over `include/kinecal.h`)
//! into a static library; `tests/library/c_abi.rs` links it with `kinecal-ffi` (which provides the
//! `kc_*` symbols) and runs it. Strict C: `-std=c99 -Wall -Wextra -Werror -pedantic`.

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let source = root.join("ffi/tests/c/host_test.c");
    let csv = root.join("ffi/tests/c/csv_test.c");
    let check = root.join("ffi/tests/c/check.h");
    let model = root.join("ffi/tests/c/model_test.c");
    for f in [&source, &csv, &check, &model] {
        println!("cargo:rerun-if-changed={}", f.display());
    }
    for h in ["include/kinecal.h", "include/kinecal_types.h"] {
        println!("cargo:rerun-if-changed={}", root.join(h).display());
    }
    cc::Build::new()
        .file(&source)
        .file(&csv)
        .file(&model)
        .include(root.join("include"))
        .std("c99")
        // The header's `kc_lm_full` (host-tests builds kinecal-ffi with its `lm-full` feature).
        .define("KC_LM_FULL", None)
        .flag("-Wall")
        .flag("-Wextra")
        .flag("-pedantic")
        .warnings_into_errors(true)
        .compile("kc_host_test");
}
