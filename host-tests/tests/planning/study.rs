//! `kinecal study` at a small size (4 of the 90 arms: the corners of the grid): the table's
//! claims of Jost et al. 2017 hold (KPI designs improve the TCP variance by at least 36 % on
//! average over random feasible poses and by at least 10 % over the O1/D-optimal design;
//! designs made without collision avoidance mostly collide), and the figure is written.

use std::process::Command;

#[test]
fn small_study_reproduces_the_papers_claims() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("study.svg");
    let out = Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
        .args([
            "study",
            "--upper-arm-mm",
            "650:1100:450",
            "--forearm-mm",
            "600:1000:400",
            "--pool",
            "1000",
            "--monte-carlo",
            "0",
            "--json",
            "--svg",
        ])
        .arg(&svg)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["arms"], 4);
    let table = v["table"].as_array().unwrap();
    assert_eq!(table.len(), 2);
    for row in table {
        let d = &row["designs"];
        let vs_random = d["random"]["kpi_improvement_mean"].as_f64().unwrap();
        let vs_d = d["d_o1"]["kpi_improvement_mean"].as_f64().unwrap();
        eprintln!(
            "collision avoidance {}: improvement vs random {vs_random:.3}, vs D/O1 {vs_d:.3}",
            row["collision_avoidance"]
        );
        assert!(vs_random >= 0.36, "{row}");
        assert!(vs_d >= 0.10, "{row}");
        assert!(d["random"]["kpi_improvement_min"].as_f64().unwrap() > 0.0);
        assert!(d["d_o1"]["kpi_improvement_min"].as_f64().unwrap() > 0.0);
    }
    // Without collision avoidance most planned poses collide (the paper: 50 % to 70 %).
    assert!(
        table[1]["colliding_share"].as_f64().unwrap() > 0.3,
        "{}",
        table[1]
    );
    for a in v["per_arm"].as_array().unwrap() {
        assert!(a["with"]["kpi"].as_f64().unwrap() < a["with"]["d_o1"].as_f64().unwrap());
    }
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<svg") && text.contains("circle"));
}
