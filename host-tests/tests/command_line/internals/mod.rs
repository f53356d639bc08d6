//! The command line's application modules one at a time: units and conventions, the map
//! format, statistics and acceptance, selection, number formatting, the diagnose explanations.

mod acceptance;
mod banded;
mod batch_avx2;
mod captured;
mod convention;
mod demo_report;
mod dense;
mod explain;
mod finite;
mod iso9283;
mod map_layout;
mod map_spec;
mod map_translate;
mod numfmt;
mod parallel;
mod refusal;
mod rotation_order;
mod rows_avx2;
mod selection;
mod stats;
mod units;
mod zero_moved;
