//! Placeholder until the firmware example lands.
fn main() {}
