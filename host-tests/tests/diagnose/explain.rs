//! The explanation of a found effect (`kinecal_cli::diagnose::explain`) against known truth:
//! size in degrees and at the tool, period, most affected poses, the share of the held-out gap;
//! and `kinecal diagnose` end to end (the `explanation` object, the text, the plot).

use crate::common::effect;
use kinecal_cli::HostRobot;

use kinecal::{ForwardKinematics, Measurement};
use kinecal_cli::commands::diagnose::{run, Args};
use kinecal_cli::diagnose::candidates::{Candidate, CandidateKind};
use kinecal_cli::diagnose::explain::{explain as explain_in, Explanation, GapBasis};
use kinecal_cli::diagnose::significance::PairedTest;
use kinecal_cli::diagnose::Found;
use kinecal_cli::formats::measurements;
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::simulation::{simulate, EffectArg, GeomErrors, Simulation};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::PathBuf;

type Arm = HostRobot<6>;

fn er20_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/er20.toml")
}

fn er20() -> Arm {
    RobotFile::load(&er20_path())
        .unwrap()
        .to_robot::<6>()
        .unwrap()
}

fn sim(effects: Vec<EffectArg>, poses: usize, noise_mm: f64, seed: u64) -> Simulation {
    Simulation {
        poses,
        noise_mm,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects,
    }
}

/// The true robot with `effects`, the same robot without them (same geometric errors, same
/// poses) and the noise-free measurements of the former.
fn truth_pair(
    effects: Vec<EffectArg>,
    poses: usize,
    seed: u64,
) -> (Arm, Arm, Vec<Measurement<f64, 6>>) {
    let (truth, d) = simulate(&er20(), &sim(effects, poses, 0.0, seed)).unwrap();
    let (plain, d0) = simulate(&er20(), &sim(Vec::new(), poses, 0.0, seed)).unwrap();
    let (d, d0) = (d.measurements::<f64>(), d0.measurements::<f64>());
    assert!(d.iter().zip(&d0).all(|(a, b)| a.q == b.q), "same poses");
    (truth, plain, d)
}

/// The explanation of `f` when the final model is the one the round fitted (`f.after`).
fn explain(f: &Found<6>, data: &[Measurement<f64, 6>], floor_mm: f64) -> Explanation {
    explain_in(f, &f.after, data, floor_mm)
}

/// A finding whose fitted model is the truth itself: what the explanation says is then a
/// property of the truth, without the search's estimation error.
fn found(candidate: Candidate, after: Arm, before: Arm, rms: [f64; 2]) -> Found<6> {
    Found {
        candidate,
        before_rms_mm: rms[0],
        validation_rms_mm: rms[1],
        test: PairedTest {
            n: 0,
            mean: 0.0,
            standard_error: 0.0,
            t: 0.0,
            p: 0.0,
        },
        threshold: 0.05,
        candidates_compared: 1,
        before,
        after,
    }
}

/// The table candidate `simulate` builds from `values` on `joint` (1-based): knots spread
/// evenly over the joint's limits, lowest limit first.
fn table_of(joint: usize, knots: usize) -> Candidate {
    let j = er20().joints()[joint - 1];
    Candidate {
        kind: CandidateKind::Table {
            start: j.lower,
            step: (j.upper - j.lower) / (knots - 1) as f64,
            knots,
        },
        joint: joint - 1,
    }
}

/// Per pose, the tool displacement of the effect by forward kinematics: `|p(with) − p(without)|`.
fn displacement(with: &Arm, without: &Arm, data: &[Measurement<f64, 6>]) -> Vec<f64> {
    let (mut a, mut b) = (ForwardKinematics::new(), ForwardKinematics::new());
    data.iter()
        .map(|m| (a.compute(with, &m.q) - b.compute(without, &m.q)).norm())
        .collect()
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// The tool figures and the most affected poses agree with the displacement computed by
/// forward kinematics with and without the effect.
fn assert_tool_figures(e: &Explanation, disp: &[f64], what: &str) {
    let (r, m) = (rms(disp), disp.iter().cloned().fold(0.0, f64::max));
    assert!(
        (e.tool_rms_mm / r - 1.0).abs() < 0.02,
        "{what}: RMS {} vs {r}",
        e.tool_rms_mm
    );
    assert!(
        (e.tool_max_mm / m - 1.0).abs() < 0.02,
        "{what}: max {} vs {m}",
        e.tool_max_mm
    );
    let mut order: Vec<usize> = (0..disp.len()).collect();
    order.sort_by(|a, b| disp[*b].total_cmp(&disp[*a]));
    assert_eq!(e.most_affected_poses.len(), 5, "{what}");
    assert_eq!(
        e.most_affected_poses[0],
        order[0] + 1,
        "{what}: {:?}",
        e.most_affected_poses
    );
    let fifth = disp[order[4]];
    for p in &e.most_affected_poses {
        assert!(
            disp[p - 1] >= 0.99 * fifth,
            "{what}: pose {p} is not among the five largest"
        );
    }
}

/// Peak to peak of the piecewise-linear table `values` (knots at `start + k·step`) over
/// `[lo, hi]`: its extremes lie at the knots inside or at the ends.
fn table_peak_to_peak(start: f64, step: f64, values: &[f64], lo: f64, hi: f64) -> f64 {
    let at = |q: f64| {
        let u = ((q - start) / step).clamp(0.0, (values.len() - 1) as f64);
        let k = (u.floor() as usize).min(values.len() - 2);
        values[k] + (values[k + 1] - values[k]) * (u - k as f64)
    };
    let mut v = vec![at(lo), at(hi)];
    for (k, x) in values.iter().enumerate() {
        let q = start + step * k as f64;
        if q > lo && q < hi {
            v.push(*x);
        }
    }
    let (a, b) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    b - a
}

fn covered(data: &[Measurement<f64, 6>], j: usize) -> (f64, f64) {
    data.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), m| {
            (a.min(m.q[j]), b.max(m.q[j]))
        })
}

/// A table holding a pure sine of period 30° at 5° knots: the period is reported, the size is
/// the sine's, the tool figures and the poses are those of forward kinematics.
#[test]
fn a_table_holding_a_sine_reports_its_period_and_size() {
    // Joint 4: limits ±180°, 73 knots every 5°; A cos(2π q / 30°) puts crests and troughs on
    // knots, so the table's peak to peak is 2A.
    let amp = 0.02f64.to_radians();
    let values: Vec<f64> = (0..73)
        .map(|k| {
            let q = -180.0 + 5.0 * k as f64;
            amp * (q / 30.0 * std::f64::consts::TAU).cos()
        })
        .collect();
    let (truth, plain, data) = truth_pair(vec![effect("joint-table", 4, &values, 1)], 200, 11);
    let c = table_of(4, 73);
    let f = found(c, truth.clone(), plain.clone(), [0.5, 0.1]);
    let e = explain(&f, &data, 0.05);
    let p = e.period_deg.expect("a period");
    assert!((p - 30.0).abs() < 0.3, "period {p}");
    assert!((e.peak_to_peak_deg.unwrap() - 0.04).abs() < 1e-9, "{e:?}");
    assert!((e.amplitude_deg.unwrap() - 0.02).abs() < 1e-9);
    assert_tool_figures(&e, &displacement(&truth, &plain, &data), "sine table");
    // Largest |dq| at the crests and troughs, every 15°: intervals around multiples of 15°.
    assert!(!e.most_affected_range_deg.is_empty());
    for [a, b] in &e.most_affected_range_deg {
        let mid = 0.5 * (a + b);
        assert!(
            b - a < 6.0 && (mid / 15.0 - (mid / 15.0).round()).abs() < 0.1,
            "{a}…{b}"
        );
    }
    assert!(e.text.contains("every 30.0°"), "{}", e.text);
    assert!(e.text.contains("and every 15.0° from there"), "{}", e.text);
    assert!(
        e.text
            .starts_with("joint 4's gearbox repeats an error of ±0.0200°"),
        "{}",
        e.text
    );
    // Gap: (0.5 − 0.1) / (0.5 − 0.05).
    assert!((e.gap_closed.unwrap() - 0.4 / 0.45).abs() < 1e-12);
    assert_eq!(e.gap_closed_of, GapBasis::NoiseFloor);
    assert!(
        e.text
            .ends_with("it closes 88.9 % of the held-out gap to the noise floor"),
        "{}",
        e.text
    );
}

/// A table of random knots has no single period; its peak to peak is the truth's over the
/// covered range; without a noise floor the gap is the relative reduction, and the text says so.
#[test]
fn a_random_table_has_no_period() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    for case in 0..4 {
        let values: Vec<f64> = (0..73)
            .map(|_| rng.random_range(-1.0..1.0) * 0.01f64.to_radians())
            .collect();
        let (truth, plain, data) =
            truth_pair(vec![effect("joint-table", 4, &values, 1)], 150, 20 + case);
        let c = table_of(4, 73);
        let e = explain(
            &found(c, truth.clone(), plain.clone(), [0.4, 0.3]),
            &data,
            f64::NAN,
        );
        assert_eq!(e.period_deg, None, "case {case}: {e:?}");
        let CandidateKind::Table { start, step, .. } = c.kind else {
            unreachable!()
        };
        let (lo, hi) = covered(&data, 3);
        let truth_ptp = table_peak_to_peak(start, step, &values, lo, hi).to_degrees();
        assert!(
            (e.peak_to_peak_deg.unwrap() / truth_ptp - 1.0).abs() < 1e-9,
            "{} vs {truth_ptp}",
            e.peak_to_peak_deg.unwrap()
        );
        assert!(e.text.contains("varies by"), "{}", e.text);
        assert_eq!(e.gap_closed_of, GapBasis::HeldOutRms);
        assert!((e.gap_closed.unwrap() - 0.25).abs() < 1e-12);
        assert!(e.text.contains("no noise floor"), "{}", e.text);
        assert_tool_figures(&e, &displacement(&truth, &plain, &data), "random table");
    }
}

/// Compliance, scale and axis-tilt: tool figures from forward kinematics, sizes from the truth.
#[test]
fn compliance_scale_and_tilt_sizes() {
    // Compliance on joint 2: k·τ over the poses' lever arms.
    let k = 3e-4;
    let (truth, plain, data) = truth_pair(vec![effect("joint-compliance", 2, &[k], 1)], 150, 5);
    let c = Candidate {
        kind: CandidateKind::Compliance,
        joint: 1,
    };
    let e = explain(
        &found(c, truth.clone(), plain.clone(), [0.3, 0.05]),
        &data,
        0.04,
    );
    let mut fk = ForwardKinematics::new();
    let taus: Vec<f64> = data
        .iter()
        .map(|m| {
            fk.compute(&plain, &m.q);
            fk.lever_arms()[1]
        })
        .collect();
    let (tlo, thi) = taus
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), t| {
            (a.min(*t), b.max(*t))
        });
    let ptp = (k * (thi - tlo)).to_degrees();
    assert!(
        (e.peak_to_peak_deg.unwrap() / ptp - 1.0).abs() < 0.01,
        "{} vs {ptp}",
        e.peak_to_peak_deg.unwrap()
    );
    assert_eq!(e.period_deg, None);
    assert!(e.most_affected_range_deg.is_empty());
    assert!(
        e.text.starts_with("joint 2 deflects under load by up to"),
        "{}",
        e.text
    );
    assert_tool_figures(&e, &displacement(&truth, &plain, &data), "compliance");
    // The gap is clamped: an addition that made things worse closed none of it.
    let worse = explain(&found(c, truth, plain, [0.3, 0.35]), &data, 0.04);
    assert_eq!(worse.gap_closed, Some(0.0));

    // Scale on joint 3: s·q over the covered range.
    let s = 4e-4;
    let (truth, plain, data) = truth_pair(vec![effect("joint-scale", 3, &[s], 1)], 150, 6);
    let c = Candidate {
        kind: CandidateKind::Scale,
        joint: 2,
    };
    let e = explain(
        &found(c, truth.clone(), plain.clone(), [0.3, 0.05]),
        &data,
        0.04,
    );
    let (lo, hi) = covered(&data, 2);
    assert!((e.peak_to_peak_deg.unwrap() / (s * (hi - lo)).to_degrees() - 1.0).abs() < 1e-9);
    // |s·q| is largest at the end of the range farther from 0.
    let far = if hi.abs() > lo.abs() { hi } else { lo }.to_degrees();
    let [a, b] = e.most_affected_range_deg[0];
    assert!(
        (a - far).abs() < 1e-6 || (b - far).abs() < 1e-6,
        "{a}…{b} vs {far}"
    );
    assert!(
        e.text.starts_with("joint 3 turns 400 ppm further"),
        "{}",
        e.text
    );
    assert_tool_figures(&e, &displacement(&truth, &plain, &data), "scale");

    // Axis-tilt of joint 3 (parallel to joint 2): the tilt itself; tool figures by FK.
    let beta = 0.05f64.to_radians();
    let (truth, plain, data) = truth_pair(vec![effect("axis-tilt", 3, &[beta], 1)], 150, 7);
    let c = Candidate {
        kind: CandidateKind::Tilt,
        joint: 2,
    };
    let e = explain(
        &found(c, truth.clone(), plain.clone(), [0.3, 0.05]),
        &data,
        0.04,
    );
    assert!((e.peak_to_peak_deg.unwrap() - 0.05).abs() < 1e-12);
    assert_eq!(e.tool_peak_to_peak_mm, None);
    assert!(
        e.text.starts_with("joint 3's axis is tilted by 0.0500°"),
        "{}",
        e.text
    );
    assert_tool_figures(&e, &displacement(&truth, &plain, &data), "tilt");
}

/// A minimal XML well-formedness check: every tag closed in order, one `<svg>` root.
fn assert_well_formed_svg(text: &str) {
    let mut stack: Vec<String> = Vec::new();
    let mut roots = 0;
    let mut rest = text;
    while let Some(i) = rest.find('<') {
        rest = &rest[i..];
        if rest.starts_with("<?") || rest.starts_with("<!") {
            let end = rest.find('>').expect("unclosed declaration");
            rest = &rest[end + 1..];
            continue;
        }
        let end = rest.find('>').expect("unclosed tag");
        let tag = &rest[1..end];
        assert!(!tag.contains('<'), "a '<' inside a tag: {tag}");
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(stack.pop().as_deref(), Some(name.trim()), "closing {name}");
        } else {
            let name: String = tag
                .chars()
                .take_while(|c| !c.is_whitespace() && *c != '/')
                .collect();
            if stack.is_empty() {
                roots += 1;
                assert_eq!(name, "svg", "root element");
            }
            if !tag.ends_with('/') {
                stack.push(name);
            }
        }
        rest = &rest[end + 1..];
    }
    assert!(stack.is_empty(), "unclosed {stack:?}");
    assert_eq!(roots, 1);
}

/// `kinecal diagnose` end to end on a known once-per-half-turn error: the `explanation` object
/// with its keys, the amplitude and period of the truth, a gap share consistent with the
/// figures, the text output and the plot with its correction and residual series.
#[test]
fn diagnose_command_explains_a_cyclic_error() {
    let tmp = tempfile::tempdir().unwrap();
    // Joint 2, order 2, amplitude 0.03° at phase 40°.
    let amp = 0.03f64.to_radians();
    let phase = 40f64.to_radians();
    let vals = [amp * phase.cos(), amp * phase.sin()];
    let (_, ds) = simulate(
        &er20(),
        &sim(vec![effect("joint-cyclic", 2, &vals, 2)], 200, 0.01, 4),
    )
    .unwrap();
    let data = tmp.path().join("d.csv");
    measurements::write(&data, &ds).unwrap();
    let plots = tmp.path().join("plots");
    let args = {
        use clap::Parser;
        #[derive(clap::Parser)]
        struct Cmd {
            #[command(flatten)]
            args: Args,
        }
        Cmd::try_parse_from([
            "diagnose",
            "--robot",
            er20_path().to_str().unwrap(),
            "--data",
            data.to_str().unwrap(),
            "--plots",
            plots.to_str().unwrap(),
        ])
        .unwrap()
        .args
    };
    let report = run(&args).unwrap();
    let r = report.to_value();
    let found = r["found"].as_array().unwrap();
    let k = found
        .iter()
        .position(|f| f["effect"] == "joint-cyclic" && f["joint"] == 2 && f["order"] == 2)
        .unwrap_or_else(|| panic!("not named: {r:#}"));
    let f = &found[k];
    let e = &f["explanation"];
    for key in [
        "peak_to_peak_deg",
        "amplitude_deg",
        "tool_rms_mm",
        "tool_max_mm",
        "period_deg",
        "most_affected_poses",
        "most_affected_range_deg",
        "gap_closed",
        "text",
    ] {
        assert!(e.get(key).is_some(), "missing explanation.{key}: {e:#}");
    }
    let a = e["amplitude_deg"].as_f64().unwrap();
    assert!((a / 0.03 - 1.0).abs() < 0.03, "amplitude {a}");
    assert!((e["peak_to_peak_deg"].as_f64().unwrap() - 2.0 * a).abs() < 1e-12);
    assert_eq!(e["period_deg"].as_f64().unwrap(), 180.0);
    // The gap share is the one of the reported figures.
    let (before, after) = (
        f["before_validation_rms_mm"].as_f64().unwrap(),
        f["validation_rms_mm"].as_f64().unwrap(),
    );
    let floor = r["noise_floor_mm"].as_f64().unwrap();
    let g = e["gap_closed"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&g));
    assert!(
        (g - ((before - after) / (before - floor)).clamp(0.0, 1.0)).abs() < 1e-12,
        "{g}"
    );
    assert!(g > 0.5, "the only effect closes most of the gap: {g}");
    let poses = e["most_affected_poses"].as_array().unwrap();
    assert_eq!(poses.len(), 5);
    assert!(poses
        .iter()
        .all(|p| (1..=200).contains(&p.as_u64().unwrap())));
    let text = e["text"].as_str().unwrap();
    assert!(
        text.starts_with("joint 2 repeats an angle error of ±"),
        "{text}"
    );
    assert!(text.contains("every 180° (twice per turn)"), "{text}");
    assert!(text.contains("and every 90.0° from there"), "{text}");
    // The text output carries the explanation and the search's sentence.
    let out = report.to_string();
    assert!(out.contains("Joint 2 repeats an angle error of ±"), "{out}");
    assert!(
        out.contains("The search: joint 2 has an angle error"),
        "{out}"
    );
    // The plot: well formed, titled with the finding, the correction over the residuals.
    let svg_path = r["plots"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap().to_string())
        .find(|p| p.contains(&format!("effect_{}_joint-cyclic_joint2", k + 1)))
        .expect("the effect's plot");
    let svg = std::fs::read_to_string(&svg_path).unwrap();
    assert_well_formed_svg(&svg);
    assert!(svg.contains("repeats an angle error of ±"), "title");
    assert!(svg.contains("identified correction"));
    assert!(svg.contains("residuals of the fit with the effect plus its correction"));
    assert!(svg.contains("joint 2 angle error (°)") && svg.contains("joint 2 reading (°)"));
    assert!(svg.contains("<polyline"), "the correction's line");
    assert!(
        svg.matches("<circle").count() >= 300,
        "the residuals' points"
    );
}

/// The explanation reads the final model (the one written), not the fit of the round that
/// added the effect: on series A a later effect took back two thirds of what joint 4's table
/// held when it was added (0.65° peak to peak there, 0.19° in the written model), and the text
/// named the round's 0.65° and 1.6 mm at the tool.
#[test]
fn the_explanation_is_of_the_final_model() {
    let amp = 0.02f64.to_radians();
    let sine = |a: f64| -> Vec<f64> {
        (0..73)
            .map(|k| a * ((-180.0 + 5.0 * k as f64) / 30.0 * std::f64::consts::TAU).cos())
            .collect()
    };
    let table = |a: f64| vec![effect("joint-table", 4, &sine(a), 1)];
    let (truth, plain, data) = truth_pair(table(amp), 200, 11);
    let (round, _, _) = truth_pair(table(3.0 * amp), 200, 11);
    let f = found(table_of(4, 73), round, plain.clone(), [0.5, 0.1]);
    let e = explain_in(&f, &truth, &data, 0.05);
    assert!((e.peak_to_peak_deg.unwrap() - 0.04).abs() < 1e-9, "{e:?}");
    assert_tool_figures(&e, &displacement(&truth, &plain, &data), "final model");
}
