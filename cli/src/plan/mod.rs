//! Measurement planning on the desktop, over the library's [`kinecal::planning`]: pools and
//! designs ([`design`], for a parameter subset with `--estimate`), the planning study of
//! Jost et al. 2017 ([`study`]) and its figure.

pub mod design;
pub mod request;
pub mod study;
pub mod study_figure;
