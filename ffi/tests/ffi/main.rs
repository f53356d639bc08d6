//! The C ABI's tests in one binary: the wrappers against the library, models loaded from
//! their binary form, and the header's currency.

mod abi;
mod c_header;
mod model;
