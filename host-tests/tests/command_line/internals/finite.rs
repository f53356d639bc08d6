//! `kinecal_cli::reports::finite` (cli/src/reports/finite.rs) on its own.

use kinecal_cli::reports::finite::first_non_finite;
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Serialize)]
struct Inner {
    rms_mm: f64,
    maybe: Option<f64>,
}

#[derive(Serialize)]
struct Outer {
    name: String,
    inner: Inner,
    list: Vec<f64>,
    map: BTreeMap<String, f64>,
}

fn outer() -> Outer {
    Outer {
        name: "x".into(),
        inner: Inner {
            rms_mm: 1.0,
            maybe: None,
        },
        list: vec![1.0, 2.0],
        map: BTreeMap::from([("a2".to_string(), 3.0)]),
    }
}

#[test]
fn finite_reports_pass_and_the_first_non_finite_number_is_named() {
    assert_eq!(first_non_finite(&outer()), None);
    let mut o = outer();
    o.inner.maybe = Some(f64::NAN);
    assert_eq!(first_non_finite(&o).as_deref(), Some("inner.maybe"));
    let mut o = outer();
    o.list[1] = f64::INFINITY;
    assert_eq!(first_non_finite(&o).as_deref(), Some("list[1]"));
    let mut o = outer();
    o.map.insert("a2".into(), f64::NEG_INFINITY);
    assert_eq!(first_non_finite(&o).as_deref(), Some("map.a2"));
}
