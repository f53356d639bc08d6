//! Measurement planning on the desktop, over the library's [`kinecal::planning`]: pools and
//! designs ([`design`]), the parameters a plan is made for ([`estimate`]), the planning study of
//! Jost et al. 2017 ([`study`]) and its figure.

pub mod design;
pub mod estimate;
pub mod study;
pub mod study_figure;
