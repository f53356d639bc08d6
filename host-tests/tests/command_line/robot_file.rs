//! The robot TOML file: round trips, and one-line errors with file:line:column.

use kinecal::model::effects::EffectKind;
use kinecal::{Frame, Joint, Robot};
use kinecal_cli::formats::robot_file::{deg_exact, deg_short, line_column, RobotFile};
use kinecal_cli::HostRobot;
use nalgebra::Vector3;
use proptest::prelude::*;

const ER20: &str = r#"name = "ER20-C10-like 6R"

[[joints]]
alpha_deg = 0.0
a_mm = 0.0
theta_deg = 0.0
d_mm = 504.0
limits_deg = [-170.0, 170.0]

[[joints]]
alpha_deg = -90.0
a_mm = 170.0
theta_deg = -90.0
d_mm = 0.0

[[joints]]
alpha_deg = 0.0
a_mm = 780.0
theta_deg = 0.0
d_mm = 0.0
beta_deg = 0.01

[[joints]]
alpha_deg = -90.0
a_mm = 140.0
theta_deg = 0.0
d_mm = 760.0

[[joints]]
alpha_deg = 90.0
a_mm = 0.0
theta_deg = 0.0
d_mm = 0.0

[[joints]]
alpha_deg = -90.0
a_mm = 0.0
theta_deg = 0.0
d_mm = 125.0

[tool]
xyz_mm = [0.0, 0.0, 100.0]

[base]
xyz_mm = [1000.0, -200.0, 30.0]
rpy_deg = [1.0, -2.0, 30.0]

[[effects]]
kind = "joint-compliance"
joint = 2
values = [0.0002]

[[effects]]
kind = "joint-cyclic"
joint = 3
values = [1e-4, -2e-4]
order = 2

[[effects]]
kind = "joint-table"
joint = 1
values = [0.0, 1e-4, -1e-4, 0.0]
step_deg = 90.0

[[effects]]
kind = "axis-tilt"
joint = 5
values = [0.001]
"#;

/// Distance in units in the last place between two finite f64 of the same sign.
fn ulps(a: f64, b: f64) -> u64 {
    if a == b {
        return 0;
    }
    if a.signum() != b.signum() {
        return u64::MAX;
    }
    a.to_bits().abs_diff(b.to_bits())
}

fn parse(text: &str) -> anyhow::Result<RobotFile> {
    RobotFile::parse(text, "r.toml")
}

/// The error message, asserting that it is one line starting with `r.toml:LINE:COL: `.
fn error_at(text: &str) -> (usize, usize, String) {
    let e = parse(text).expect_err("must be refused");
    let msg = format!("{e:#}");
    assert!(!msg.contains('\n'), "one line: {msg}");
    let rest = msg
        .strip_prefix("r.toml:")
        .unwrap_or_else(|| panic!("names the file: {msg}"));
    let mut it = rest.splitn(3, ':');
    let line: usize = it
        .next()
        .unwrap()
        .parse()
        .unwrap_or_else(|_| panic!("line number: {msg}"));
    let col: usize = it
        .next()
        .unwrap()
        .parse()
        .unwrap_or_else(|_| panic!("column number: {msg}"));
    (line, col, it.next().unwrap().trim().to_string())
}

/// Replaces the first occurrence of `from` in the ER20 text.
fn er20_with(from: &str, to: &str) -> String {
    assert!(ER20.contains(from), "{from}");
    ER20.replacen(from, to, 1)
}

fn line_of(text: &str, needle: &str) -> usize {
    line_column(text, text.find(needle).unwrap()).0
}

#[test]
fn reads_every_table() {
    let f = parse(ER20).unwrap();
    assert_eq!(f.joint_count(), 6);
    assert!(f.base_known());
    assert_eq!(f.tilt_joints(), vec![4]);
    let r = f.to_robot::<6>().unwrap();
    let j = r.joints();
    assert_eq!(j[0].d, 504.0);
    assert_eq!(j[0].lower, (-170f64).to_radians());
    assert_eq!(j[1].lower, -std::f64::consts::PI, "default limits ±180°");
    assert_eq!(j[2].beta, 0.01f64.to_radians());
    assert_eq!(j[4].beta, 0.001, "axis-tilt's value is beta in rad");
    assert_eq!(r.tool(), &Vector3::new(0.0, 0.0, 100.0));
    assert_eq!(r.base().o, Vector3::new(1000.0, -200.0, 30.0));
    let rpy = r.base().rpy();
    for (a, b) in rpy.iter().zip([1.0, -2.0, 30.0f64]) {
        assert!((a - b.to_radians()).abs() < 1e-14);
    }
    let e = r.effects();
    assert_eq!(e.len(), 3);
    assert_eq!(e.get(0).unwrap().kind, EffectKind::Compliance);
    assert_eq!(e.get(0).unwrap().joint, 1);
    assert_eq!(e.get(1).unwrap().order, 2);
    let t = e.get(2).unwrap();
    assert_eq!(t.kind, EffectKind::Table);
    assert_eq!(
        t.start,
        (-170f64).to_radians(),
        "table starts at the lower limit by default"
    );
    assert_eq!(t.step, 90f64.to_radians());
    assert_eq!(e.values(), &[0.0002, 1e-4, -2e-4, 0.0, 1e-4, -1e-4, 0.0]);
}

#[test]
fn the_ur10_file_loads_without_base() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/ur10/robot.toml");
    let f = RobotFile::load(&path).unwrap();
    assert_eq!(f.joint_count(), 6);
    assert!(!f.base_known());
    let r = f.to_robot::<6>().unwrap();
    assert_eq!(r.base(), &Frame::identity());
    assert_eq!(r.joints()[2].a, 612.7);
}

#[test]
fn file_round_trip_is_exact() {
    let f = parse(ER20).unwrap();
    let text = f.to_toml().unwrap();
    let g = parse(&text).unwrap();
    assert_eq!(f, g);
    // And the model built from both is identical.
    assert_eq!(f.to_robot::<6>().unwrap(), g.to_robot::<6>().unwrap());
}

#[test]
fn start_deg_is_written_and_honoured() {
    let text = er20_with("step_deg = 90.0", "step_deg = 3.6\nstart_deg = -12.5");
    let r = parse(&text).unwrap().to_robot::<6>().unwrap();
    assert_eq!(r.effects().get(2).unwrap().start, (-12.5f64).to_radians());
}

#[test]
fn save_and_load_through_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("m.toml");
    let f = parse(ER20).unwrap();
    f.save(&p).unwrap();
    assert_eq!(RobotFile::load(&p).unwrap(), f);
}

/// Rows (alpha, a, theta, d, beta), tool, base (xyz, rpy), effect values, base known.
type Model = (Vec<[f64; 5]>, [f64; 3], [f64; 6], Vec<f64>, bool);

fn arb_model() -> impl Strategy<Value = Model> {
    (
        prop::collection::vec(
            (
                -3.2f64..3.2,
                -900.0f64..900.0,
                -3.2f64..3.2,
                -900.0f64..900.0,
                -0.01f64..0.01,
            )
                .prop_map(|(a, b, c, d, e)| [a, b, c, d, e]),
            6,
        ),
        prop::array::uniform3(-300.0f64..300.0),
        (
            prop::array::uniform3(-5000.0f64..5000.0),
            prop::array::uniform3(-3.0f64..3.0),
        )
            .prop_map(|(a, b)| [a[0], a[1], a[2], b[0], b[1], b[2]]),
        prop::collection::vec(-1e-3f64..1e-3, 10),
        any::<bool>(),
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// An identified model (arbitrary f64 values everywhere) survives write → read bit for bit,
    /// except the base orientation (stored as roll/pitch/yaw), which survives to rounding.
    #[test]
    fn model_round_trip((rows, tool, base, vals, base_known) in arb_model()) {
        let joints: [Joint<f64>; 6] = std::array::from_fn(|i| {
            let [alpha, a, theta, d, beta] = rows[i];
            Joint { alpha, a, theta, d, beta, lower: -2.5 - i as f64 * 0.1, upper: 2.0 + i as f64 * 0.3 }
        });
        let b = Frame::from_xyz_rpy([base[0], base[1], base[2]], [base[3], base[4] * 0.5, base[5]]);
        let mut r: HostRobot<6> = Robot::new(b, joints, Vector3::from(tool)).unwrap();
        let e = r.effects_mut();
        e.push(EffectKind::Scale, 0, 6, 1, 0.0, 0.0, &vals[0..1]).unwrap();
        e.push(EffectKind::Cyclic, 1, 6, 3, 0.0, 0.0, &vals[1..3]).unwrap();
        e.push(EffectKind::Compliance, 2, 6, 1, 0.0, 0.0, &vals[3..4]).unwrap();
        e.push(EffectKind::Table, 5, 6, 1, -1.234_567_890_123, 0.062_831_853_071_795_86, &vals[4..10]).unwrap();
        let file = RobotFile::from_robot("identified", &r, base_known, &[3]);
        let text = file.to_toml().unwrap();
        let back = parse(&text).unwrap();
        prop_assert_eq!(back.base_known(), base_known);
        prop_assert_eq!(back.tilt_joints(), vec![3]);
        let r2 = back.to_robot::<6>().unwrap();
        // Lengths exactly; angles to the last bit where a degree value converting back to
        // exactly these radians exists (almost always), else within one ulp.
        for (a, b) in r.joints().iter().zip(r2.joints()) {
            prop_assert_eq!((a.a, a.d), (b.a, b.d));
            for (x, y) in [(a.alpha, b.alpha), (a.theta, b.theta), (a.beta, b.beta), (a.lower, b.lower), (a.upper, b.upper)] {
                prop_assert!(ulps(x, y) <= 1, "{} vs {}", x, y);
            }
        }
        prop_assert_eq!(r2.tool(), r.tool());
        prop_assert_eq!(r2.effects().values(), r.effects().values());
        for (a, b) in r.effects().iter().zip(r2.effects().iter()) {
            prop_assert_eq!((a.kind, a.joint, a.order, a.first, a.len), (b.kind, b.joint, b.order, b.first, b.len));
            prop_assert!(ulps(a.start, b.start) <= 1 && ulps(a.step, b.step) <= 1);
        }
        if base_known {
            let (b1, b2) = (r.base(), r2.base());
            prop_assert_eq!(b1.o, b2.o);
            for (u, v) in [(b1.x, b2.x), (b1.y, b2.y), (b1.z, b2.z)] {
                prop_assert!((u - v).norm() < 1e-14, "{} vs {}", u, v);
            }
        } else {
            prop_assert_eq!(r2.base(), &Frame::identity());
        }
        // And the file itself is a fixed point.
        prop_assert_eq!(parse(&back.to_toml().unwrap()).unwrap(), back);
    }

    /// Degrees are chosen so that converting back gives the same radians, or the nearest
    /// reachable value: not every f64 radian value is the image of an f64 degree value.
    #[test]
    fn degrees_round_trip(x in -10.0f64..10.0) {
        prop_assert!(ulps(deg_exact(x).to_radians(), x) <= 1);
    }
}

#[test]
fn syntax_error_gives_line_and_column() {
    let text = er20_with("d_mm = 504.0", "d_mm = = 504.0");
    let (line, col, msg) = error_at(&text);
    assert_eq!(line, line_of(&text, "d_mm = = 504.0"));
    assert_eq!(col, 8, "{msg}");
}

#[test]
fn unterminated_string_and_bad_header() {
    let (line, _, _) = error_at("name = \"abc\n[[joints]]\n");
    assert_eq!(line, 1);
    let text = er20_with("[tool]", "[tool");
    let (line, _, _) = error_at(&text);
    assert_eq!(line, line_of(&text, "[tool\n"));
}

#[test]
fn wrong_type_points_at_the_value() {
    let text = er20_with("a_mm = 780.0", "a_mm = \"780\"");
    let (line, _, msg) = error_at(&text);
    assert_eq!(line, line_of(&text, "a_mm = \"780\""), "{msg}");
}

#[test]
fn missing_keys_are_named() {
    let text = er20_with("d_mm = 760.0\n", "");
    let (line, _, msg) = error_at(&text);
    assert!(msg.contains("d_mm"), "{msg}");
    // The error points into the fourth joint's table.
    let start = line_of(&text, "a_mm = 140.0");
    assert!(
        (start - 3..=start + 2).contains(&line),
        "line {line}: {msg}"
    );

    let no_tool = er20_with("[tool]\nxyz_mm = [0.0, 0.0, 100.0]\n", "");
    let (_, _, msg) = error_at(&no_tool);
    assert!(msg.contains("tool"), "{msg}");

    let (_, _, msg) = error_at("name = \"no joints\"\n[tool]\nxyz_mm = [0.0, 0.0, 0.0]\n");
    assert!(msg.contains("joints"), "{msg}");
}

#[test]
fn unknown_keys_in_tables_are_refused() {
    let text = er20_with("beta_deg = 0.01", "beta_dg = 0.01");
    let (line, _, msg) = error_at(&text);
    assert!(msg.contains("beta_dg"), "{msg}");
    assert_eq!(line, line_of(&text, "beta_dg"));
}

#[test]
fn misspelt_tables_are_refused() {
    let text = er20_with("[[joints]]", "[[joint]]");
    let (_, _, msg) = error_at(&text);
    assert!(msg.contains("joint"), "{msg}");
}

#[test]
fn bad_effect_kind_points_at_its_table() {
    let text = er20_with("kind = \"joint-compliance\"", "kind = \"joint-backlash\"");
    let (line, _, msg) = error_at(&text);
    assert!(msg.contains("joint-backlash"), "{msg}");
    let at = line_of(&text, "joint-backlash");
    assert!(line + 1 >= at && line <= at, "line {line} vs {at}: {msg}");
}

#[test]
fn value_problems_are_refused_with_their_place() {
    let cases: Vec<(String, &str, &str)> = vec![
        (
            er20_with("joint = 2\n", "joint = 7\n"),
            "joint = 7",
            "joint",
        ),
        (
            er20_with("joint = 2\n", "joint = 0\n"),
            "joint = 0",
            "joint",
        ),
        (
            er20_with("values = [0.0002]", "values = [0.0002, 1.0]"),
            "values = [0.0002, 1.0]",
            "value",
        ),
        (
            er20_with("values = [1e-4, -2e-4]", "values = [1e-4]"),
            "values = [1e-4]",
            "value",
        ),
        (er20_with("order = 2", "order = 0"), "order = 0", "order"),
        (
            er20_with("step_deg = 90.0", "step_deg = -1.0"),
            "step_deg = -1.0",
            "step_deg",
        ),
        (
            er20_with("step_deg = 90.0\n", ""),
            "kind = \"joint-table\"",
            "step_deg",
        ),
        (
            er20_with(
                "limits_deg = [-170.0, 170.0]",
                "limits_deg = [170.0, -170.0]",
            ),
            "limits_deg = [170.0, -170.0]",
            "limits",
        ),
        (
            er20_with("d_mm = 125.0", "d_mm = nan"),
            "d_mm = nan",
            "finite",
        ),
        (
            er20_with("xyz_mm = [0.0, 0.0, 100.0]", "xyz_mm = [0.0, inf, 100.0]"),
            "xyz_mm = [0.0, inf",
            "finite",
        ),
        (
            er20_with("rpy_deg = [1.0, -2.0, 30.0]", "rpy_deg = [1.0, -nan, 30.0]"),
            "rpy_deg = [1.0, -nan",
            "finite",
        ),
    ];
    for (text, near, word) in cases {
        let (line, _, msg) = error_at(&text);
        assert!(msg.contains(word), "`{word}` in: {msg}");
        let at = line_of(&text, near);
        assert!(
            line <= at && at <= line + 8,
            "error line {line} should be the table holding line {at}: {msg}"
        );
    }
}

#[test]
fn joint_count_is_checked() {
    let one = "[[joints]]\nalpha_deg = 0.0\na_mm = 0.0\ntheta_deg = 0.0\nd_mm = 1.0\n[tool]\nxyz_mm = [0.0, 0.0, 0.0]\n";
    let (_, _, msg) = error_at(one);
    assert!(msg.contains("1 joints"), "{msg}");
    let f = parse(ER20).unwrap();
    assert!(f.to_robot::<7>().is_err());
}

#[test]
fn not_utf8_and_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    std::fs::write(&p, b"name = \"x\"\nfoo = \"\xff\"\n").unwrap();
    let msg = format!("{:#}", RobotFile::load(&p).unwrap_err());
    assert!(msg.starts_with(&format!("{}:2:8:", p.display())), "{msg}");
    let msg = format!(
        "{:#}",
        RobotFile::load(&dir.path().join("none.toml")).unwrap_err()
    );
    assert!(msg.contains("none.toml") && !msg.contains('\n'), "{msg}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// A user's short decimal (up to 6 decimals, within ±400°) comes back as exactly that
    /// number, not `-59.99999999999999`; and any angle comes back bit-exact whenever a degree
    /// value that converts back to it exists (the guarantee of `deg_exact`).
    #[test]
    fn short_degrees_come_back_as_written(k in -400_000_000i64..400_000_000, m in 0u32..7) {
        let d = k as f64 / 10f64.powi(m as i32);
        let d: f64 = format!("{d:.*}", m as usize).parse().unwrap();
        let back = deg_short(d.to_radians());
        prop_assert_eq!(back, d, "{} -> {} rad -> {}", d, d.to_radians(), back);
        prop_assert_eq!(back.to_string(), d.to_string());
    }

    #[test]
    fn short_degrees_keep_the_exact_read_back(x in -7.0f64..7.0) {
        let s = deg_short(x);
        if deg_exact(x).to_radians() == x {
            prop_assert_eq!(s.to_radians(), x);
        }
        prop_assert!(ulps(s.to_radians(), x) <= 1);
        let (short, exact) = (s.to_string(), deg_exact(x).to_string());
        prop_assert!(short.len() <= exact.len(), "{} longer than {}", short, exact);
    }
}

/// `identify --out` writes the user's limits back as given (`-60.0`, the shortest decimal
/// that reads back), and the written model reads back bit-exact.
#[test]
fn out_writes_limits_as_given_and_reads_back_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let text = er20_with("limits_deg = [-170.0, 170.0]", "limits_deg = [-60.0, 33.3]").replacen(
        "d_mm = 0.0\n",
        "d_mm = 0.0\nlimits_deg = [-147.25, 92.1]\n",
        1,
    );
    let robot = dir.path().join("r.toml");
    std::fs::write(&robot, &text).unwrap();
    let data = dir.path().join("d.csv");
    let model = dir.path().join("m.toml");
    let bin = env!("CARGO_BIN_EXE_kinecal-under-test");
    let run = |args: &[&str]| {
        let o = std::process::Command::new(bin).args(args).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    let p = |x: &std::path::Path| x.to_str().unwrap().to_string();
    run(&[
        "simulate",
        "--robot",
        &p(&robot),
        "--poses",
        "60",
        "--noise-mm",
        "0.01",
        "--geom-errors",
        "--out",
        &p(&data),
    ]);
    run(&[
        "identify",
        "--robot",
        &p(&robot),
        "--data",
        &p(&data),
        "--out",
        &p(&model),
    ]);
    let written = std::fs::read_to_string(&model).unwrap();
    assert!(written.contains("limits_deg = [-60.0, 33.3]"), "{written}");
    assert!(
        written.contains("limits_deg = [-147.25, 92.1]"),
        "{written}"
    );
    // Every angle the user gave comes back as given: limits, the base orientation too.
    assert!(written.contains("rpy_deg = [1.0, -2.0, 30.0]"), "{written}");
    for l in written
        .lines()
        .filter(|l| l.starts_with("limits_deg") || l.starts_with("rpy_deg"))
    {
        assert!(!l.contains("99999") && !l.contains("00000"), "{l}");
    }
    // Read back: bit for bit the model that was written.
    let back = RobotFile::load(&model).unwrap();
    let r = back.to_robot::<6>().unwrap();
    let again = RobotFile::from_robot(&back.name, &r, true, &back.tilt_joints());
    assert_eq!(again, back, "written model is a fixed point");
    let nominal = parse(&text).unwrap().to_robot::<6>().unwrap();
    for (a, b) in nominal.joints().iter().zip(r.joints()) {
        assert_eq!(
            (a.lower.to_bits(), a.upper.to_bits()),
            (b.lower.to_bits(), b.upper.to_bits())
        );
    }
    // The nominal file written from its model: every angle as the user wrote it.
    let f = parse(&text).unwrap();
    let from = RobotFile::from_robot(&f.name, &nominal, true, &f.tilt_joints());
    for (a, b) in f.joints.iter().zip(&from.joints) {
        assert_eq!((a.alpha_deg, a.theta_deg), (b.alpha_deg, b.theta_deg));
        if let Some(l) = a.limits_deg {
            assert_eq!(Some(l), b.limits_deg);
        }
    }
}

/// Joint limits written in radians (every joint within ±6.3°: no arm stops there) are refused
/// saying so, before `plan` confines a session to ±6.3° of zero; one joint with narrow limits
/// among others is a robot file like any other.
#[test]
fn joint_limits_in_radians_are_refused() {
    let ur10 = std::fs::read_to_string(crate::common::ur10_dir().join("robot.toml")).unwrap();
    assert!(ur10.contains("limits_deg = [-360.0, 360.0]"));
    let radians = ur10.replace(
        "limits_deg = [-360.0, 360.0]",
        "limits_deg = [-6.283185, 6.283185]",
    );
    let e = format!("{:#}", parse(&radians).unwrap_err());
    assert!(
        e.contains("these read as radians") && e.contains("multiply them by 180/π"),
        "{e}"
    );
    let narrow = ur10.replacen(
        "limits_deg = [-360.0, 360.0]",
        "limits_deg = [-5.0, 5.0]",
        1,
    );
    parse(&narrow).unwrap();
    parse(&ur10).unwrap();
}

/// `identify --effect axis-tilt:3`: the tilt was estimated (the text report listed `beta3`),
/// but JSON `parameters` left it out, and the model written carried `beta_deg` without the
/// `axis-tilt` effect docs/formats.md promises, so identifying from it again held the tilt.
/// Now `parameters` has `beta3` at the truth, the model an `axis-tilt` on joint 3, and a
/// re-identification from it estimates `beta3` again.
#[test]
fn an_estimated_axis_tilt_is_reported_and_written_to_be_freed_again() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = crate::common::data_file("er20.toml");
    let data = d.join("m.csv");
    crate::common::simulate(
        &robot,
        Some(300),
        Some(0.01),
        Some(4),
        &["--geom-errors", "--effect", "axis-tilt:3:0.001"],
        &data,
    );
    let cal = d.join("cal.toml");
    let args = [
        "--effect",
        "axis-tilt:3",
        "--holdout",
        "0.3",
        "--out",
        crate::common::s(&cal),
        "--json",
    ];
    let j = crate::common::json_of(&crate::common::run_on("identify", &robot, &data, &args));
    let beta3 = j["parameters"]["beta3"]
        .as_f64()
        .expect("beta3 in parameters");
    let truth = 0.001f64.to_degrees();
    assert!(
        (beta3 - truth).abs() < 0.05 * truth,
        "beta3 {beta3}° against {truth}°"
    );
    let model = RobotFile::load(&cal).unwrap();
    assert_eq!(model.tilt_joints(), vec![2], "{:?}", model.effects);
    // The same data again: no better than the model (exit 3 either way), but beta3 estimated.
    let again = crate::common::run_on("identify", &cal, &data, &["--holdout", "0.3", "--json"]);
    let again: serde_json::Value = serde_json::from_slice(&again.stdout).unwrap();
    // Estimated (a held parameter has no σ).
    assert!(
        again["changes"]["beta3"]["data_sigma"].is_number(),
        "{}",
        again["changes"]
    );
}

/// `export --format firmware` of a 5-joint model wrote a blob (exit 0) that the C ABI's
/// `kc_robot_load` (6 or 7 joints) refuses as "truncated, corrupted…". It is still written (a
/// Rust firmware decodes it) with a warning that names the joint count; 6 joints draw none.
#[test]
fn a_firmware_export_the_c_abi_cannot_load_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(crate::common::data_file("er20.toml")).unwrap();
    // The ER20 without its sixth row.
    let sixth = text.match_indices("[[joints]]").nth(5).unwrap().0;
    let tool = text.find("[tool]").unwrap();
    let five = format!("{}{}", &text[..sixth], &text[tool..]);
    // Tables of 681 knots (0.5° over ±170°) on joints 1 and 2: more values than the C ABI holds.
    let knots = vec!["0.0"; 681].join(", ");
    let table = |j: usize| {
        format!("\n[[effects]]\nkind = \"joint-table\"\njoint = {j}\nstep_deg = 0.5\nstart_deg = -170.0\nvalues = [{knots}]\n")
    };
    let fine = format!("{text}{}{}", table(1), table(2));
    let fine_warned = crate::common::write(dir.path(), "fine.toml", &fine);
    let out = crate::common::kinecal(&[
        "export",
        "--model",
        crate::common::s(&fine_warned),
        "--format",
        "firmware",
        "--out",
        crate::common::s(&dir.path().join("fine.kcm")),
    ]);
    let err = crate::common::stderr(&out);
    assert!(
        err.contains("1362 effect values") && err.contains("holds 1024"),
        "{err}"
    );
    for (name, robot, warned) in [("five.toml", five, true), ("six.toml", text, false)] {
        let path = crate::common::write(dir.path(), name, &robot);
        let blob = dir.path().join("m.kcm");
        let out = crate::common::kinecal(&[
            "export",
            "--model",
            crate::common::s(&path),
            "--format",
            "firmware",
            "--out",
            crate::common::s(&blob),
        ]);
        let err = crate::common::stderr(&out);
        assert_eq!(out.status.code(), Some(0), "{name}: {err}");
        assert!(blob.exists());
        assert_eq!(
            err.contains("kc_robot_load holds 6 or 7"),
            warned,
            "{name}: {err}"
        );
    }
}
