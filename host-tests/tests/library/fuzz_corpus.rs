//! Every committed fuzz input replayed through its target with the stable toolchain: the
//! minimised corpus of each target (`fuzz/corpus/<target>/`) and every reproducer that once
//! failed an invariant (`fuzz/regressions/<target>/`, fuzz/README.md lists the defects). The
//! targets' bodies are the fuzz crate's modules (`fuzz/src/<target>.rs`), built for this replay
//! by the crate `host-tests/fuzz-targets` (unoptimised: the build, not the replay, is what costs);
//! an input that panics fails the test with the file's name and the invariant's message. Fuzzing itself (new inputs) stays with `scripts/fuzz`.

use kinecal_fuzz as targets;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// The files of `fuzz/<kind>/<target>/`, sorted (none when the folder does not exist).
fn inputs(kind: &str, target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fuzz")
        .join(kind)
        .join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|d| {
            d.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file())
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    files
}

/// Runs `run` on each committed input of `target`; fails listing every input that panicked.
fn replay(target: &str, run: fn(&[u8])) {
    let corpus = inputs("corpus", target);
    let regressions = inputs("regressions", target);
    assert!(!corpus.is_empty(), "fuzz/corpus/{target}/ has no inputs");
    let mut failed = Vec::new();
    for file in corpus.iter().chain(&regressions) {
        let data = std::fs::read(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        if let Err(p) = catch_unwind(AssertUnwindSafe(|| run(&data))) {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            failed.push(format!("{}: {msg}", file.display()));
        }
    }
    println!(
        "{target}: {} corpus inputs and {} regressions replayed",
        corpus.len(),
        regressions.len()
    );
    assert!(
        failed.is_empty(),
        "{} of the inputs of {target} failed:\n{}",
        failed.len(),
        failed.join("\n")
    );
}

macro_rules! replay_tests {
    ($($target:ident),* $(,)?) => {
        $(
            #[test]
            fn $target() {
                replay(stringify!($target), targets::$target::run);
            }
        )*
    };
}

replay_tests!(
    compensation,
    construction,
    csv_reader,
    decimal,
    kinematics,
    measurement_file,
    model_blob,
    robot_file,
    snapshots,
    steppers,
    urdf,
);
