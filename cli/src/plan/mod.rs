//! Measurement planning on the desktop: the study figure (the pools and designs follow the
//! library's [`kinecal::planning`]).

pub mod study_figure;
