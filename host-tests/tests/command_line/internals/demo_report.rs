//! `kinecal_cli::reports::demo` (cli/src/reports/demo.rs) on its own.

use kinecal_cli::reports::demo::*;

fn row(method: &str, iterations: u32) -> MethodRow {
    let e = DemoErrors {
        identification_rms_mm: 1.0,
        validation_rms_mm: 2.0,
        validation_mean_mm: 1.5,
        validation_max_mm: 3.0,
    };
    MethodRow {
        method: method.into(),
        iterations,
        evaluations: 10,
        best_fitness: 0.0123,
        seconds: 0.5,
        before: e,
        after: e,
        iterations_to_final: None,
        iterations_to_pso_final: None,
    }
}

/// Every column of the table ends where its heading ends, whatever the iteration count.
#[test]
fn the_table_columns_line_up() {
    let r = DemoReport {
        robot: "ER20-C10 stand-in".into(),
        noise_mm: 0.01,
        n_identification: 50,
        n_validation: 50,
        factory_pso_iterations: 1000,
        drift: Drift {
            angle_deg: 0.002,
            length_mm: 0.01,
            validation_rms_mm: Some(0.07),
        },
        methods: vec![row("pso", 1000), row("lm", 4), row("pso+lm", 1004)],
        bpnn_pso_iteration_ratio: None,
        figures: Vec::new(),
    };
    let text = r.to_string();
    assert!(text.starts_with(
        "BPNN-PSO paper simulation (ER20-C10 stand-in, 50 + 50 poses, 10 µm noise)\n"
    ));
    let lines: Vec<&str> = text.lines().collect();
    let head = lines[2];
    let ends = |l: &str| -> Vec<usize> {
        let mut v = Vec::new();
        let chars: Vec<char> = l.chars().collect();
        for i in 0..chars.len() {
            if chars[i] != ' ' && chars.get(i + 1).is_none_or(|c| *c == ' ') {
                v.push(i);
            }
        }
        v
    };
    // The heading "best fitness" has a space inside: compare the right-aligned columns by
    // their last characters, method (left-aligned) aside.
    let h = ends(head);
    for l in &lines[3..6] {
        let e = ends(l);
        assert_eq!(e.len(), 8, "{l}");
        assert_eq!(
            e[1..],
            [h[1], h[3], h[4], h[6], h[8], h[10], h[12]],
            "{l}\n{head}"
        );
    }
}
