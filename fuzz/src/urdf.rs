//! The command line's URDF reader (`Urdf::parse`, the chain search and the MDH conversion of
//! `kinecal import`) and the exporter (`splice::export`, `kinecal export --urdf`), on any text.
//!
//! Invariants:
//! - `no-panic` on any text, however nested, cyclic or large;
//! - `imported-finite`: a URDF that imports gives a robot file that validates and whose every
//!   number is finite;
//! - `export-well-formed`: the export of the imported model into its own URDF is read again
//!   by the same reader (it is well-formed XML and a URDF);
//! - `export-round-trip`: that export imports again, with the tip `kinecal_tool` the exporter
//!   adds, to a chain of as many revolute joints.

use super::invariant;
use kinecal_cli::commands::import::import_chain;
use kinecal_cli::formats::urdf::{parse::Urdf, splice};
use std::path::Path;

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(urdf) = Urdf::parse(text, "fuzz.urdf") else {
        return;
    };
    let path = Path::new("fuzz.urdf");
    let Ok((imported, _base, tip, _fixed)) = import_chain(&urdf, path, None, None, [0.0; 3]) else {
        return;
    };
    let file = &imported.file;
    let numbers_finite = file.joints.iter().all(|j| {
        [j.alpha_deg, j.a_mm, j.theta_deg, j.d_mm]
            .iter()
            .all(|v| v.is_finite())
    }) && file.tool.xyz_mm.iter().all(|v| v.is_finite());
    invariant!("imported-finite", numbers_finite, "{file:?}");
    invariant!("imported-finite", file.validate().is_ok(), "{file:?}");
    // The nominal model exported into the URDF it came from: nothing to refuse.
    let Ok(written) = splice::export(text, &urdf, &imported, file, &tip, "fuzz.urdf") else {
        return;
    };
    let again = Urdf::parse(&written, "export.urdf");
    invariant!(
        "export-well-formed",
        again.is_ok(),
        "{:?}\n{written}",
        again.err()
    );
    let again = again.unwrap();
    let back = import_chain(&again, path, None, Some("kinecal_tool"), [0.0; 3]);
    invariant!(
        "export-round-trip",
        back.as_ref()
            .is_ok_and(|(b, ..)| b.file.joints.len() == file.joints.len()),
        "{:?}\n{written}",
        back.err()
    );
}
