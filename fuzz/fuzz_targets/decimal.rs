//! The `decimal` fuzz target: its input and invariants are in `fuzz/src/decimal.rs`, which the
//! host tests also replay over the committed corpus (`host-tests/tests/library/fuzz_corpus.rs`).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| kinecal_fuzz::decimal::run(data));
