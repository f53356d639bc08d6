//! `kinecal_cli::calibration::selection` (cli/src/calibration/selection.rs) on its own.

use kinecal::model::effects::EffectKind;
use kinecal::model::param::Param;
use kinecal_cli::calibration::selection::*;
use kinecal_cli::HostRobot;

fn robot() -> HostRobot<6> {
    let mut r = kinecal_cli::simulation::er20_c10();
    r.effects_mut()
        .push(EffectKind::Table, 0, 6, 0, -0.1, 0.05, &[0.0; 5])
        .unwrap();
    r.effects_mut()
        .push(EffectKind::Cyclic, 2, 6, 1, 0.0, 0.0, &[0.0; 2])
        .unwrap();
    r
}

fn names(r: &HostRobot<6>, p: &[Param]) -> Vec<String> {
    p.iter().map(|p| p.name(r).to_string()).collect()
}

fn s(v: &[&str]) -> Vec<String> {
    v.iter().map(|x| x.to_string()).collect()
}

#[test]
fn only_replaces_the_list_and_reaches_a_known_base() {
    let r = robot();
    let mut p = vec![Param::Theta(0), Param::D(1)];
    let only = s(&["base", "theta2", "joint-table1"]);
    apply(
        &mut p,
        &r,
        &Selection {
            only: &only,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(
        names(&r, &p),
        [
            "base.x",
            "base.y",
            "base.z",
            "base.rx",
            "base.ry",
            "base.rz",
            "theta2",
            "joint-table1[0]",
            "joint-table1[1]",
            "joint-table1[2]",
            "joint-table1[3]",
            "joint-table1[4]"
        ]
    );
}

#[test]
fn printed_effect_names_and_groups_fix_and_free() {
    let r = robot();
    let mut p: Vec<Param> = (0..7).map(|k| Param::Effect(k as u16)).collect();
    p.push(Param::A(2));
    let fix = s(&["joint-table1[0]", "joint-cyclic3.n1.b"]);
    let free = s(&["beta3"]);
    let sel = Selection {
        fix: &fix,
        free: &free,
        ..Default::default()
    };
    apply(&mut p, &r, &sel).unwrap();
    let n = names(&r, &p);
    assert!(!n.contains(&"joint-table1[0]".to_string()));
    assert!(!n.contains(&"joint-cyclic3.n1.b".to_string()));
    assert!(n.contains(&"joint-cyclic3.n1.a".to_string()));
    assert!(n.contains(&"beta3".to_string()) && n.contains(&"a3".to_string()));
    let mut q = p.clone();
    let fix = s(&["effects", "geometry"]);
    apply(
        &mut q,
        &r,
        &Selection {
            fix: &fix,
            ..Default::default()
        },
    )
    .unwrap_err();
    let fix = s(&["geometry"]);
    apply(
        &mut q,
        &r,
        &Selection {
            fix: &fix,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(q.iter().all(|p| matches!(p, Param::Effect(_))));
}

#[test]
fn unknown_names_are_refused() {
    let r = robot();
    for bad in [
        "theta7",
        "joint-table2",
        "tool3.x",
        "nope",
        "joint-table1[9]",
    ] {
        let mut p = vec![Param::Theta(0)];
        let fix = s(&[bad]);
        let e = apply(
            &mut p,
            &r,
            &Selection {
                fix: &fix,
                ..Default::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains(bad), "{e}");
    }
}
