//! What the commands write: files replaced atomically, numbers for people, SVG charts.

pub mod atomic;
pub mod numfmt;
pub mod plots;
