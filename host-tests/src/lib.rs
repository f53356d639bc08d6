//! Cross-checks of kinecal: an independent `f64` reference of docs/formats.md and the tests,
//! benchmarks and scripts that hold the library and the command line to it.

pub mod c_abi;
pub mod constraint_reference;
pub mod reference;
