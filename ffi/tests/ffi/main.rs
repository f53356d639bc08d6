//! The C ABI's tests in one binary: the wrappers against the library, and the header's currency.

mod abi;
mod c_header;
