//! Export: a calibrated model spliced into the URDF reproduces its kinematics, the rest untouched.

use super::*;

/// The nominal-based model of `file` with `base` as base (the URDF's view of the robot).
fn with_base(model: &RobotFile, nominal: &RobotFile) -> RobotFile {
    let mut m = model.clone();
    m.base = nominal.base.clone();
    m
}

#[test]
fn calibrated_model_exported_to_urdf_reproduces_its_forward_kinematics() {
    for (folder, file, extra) in [URDFS[1], URDFS[2], URDFS[4]] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let path = urdf_path(folder, file);
        let (robot_path, nominal) = import(d, &path, extra);
        let data = d.join("meas.csv");
        let truth = d.join("truth.toml");
        crate::common::simulate(
            &robot_path,
            Some(300),
            Some(0.005),
            Some(3),
            &["--geom-errors", "--truth", s(&truth)],
            &data,
        );
        let model_path = d.join("model.toml");
        kinecal_ok(&[
            "identify",
            "--robot",
            s(&robot_path),
            "--data",
            s(&data),
            "--out",
            s(&model_path),
        ]);
        let model = RobotFile::load(&model_path).unwrap();
        // [tool] rpy_deg is carried through simulate --truth and identify --out.
        assert!(nominal.tool.rpy_deg.is_some());
        assert_eq!(model.tool.rpy_deg, nominal.tool.rpy_deg, "{file}");
        assert_eq!(
            RobotFile::load(&truth).unwrap().tool.rpy_deg,
            nominal.tool.rpy_deg
        );
        let moved = model
            .joints
            .iter()
            .zip(&nominal.joints)
            .any(|(a, b)| (a.a_mm - b.a_mm).abs() > 0.01 || (a.d_mm - b.d_mm).abs() > 0.01);
        assert!(
            moved,
            "{file}: the identified model differs from the nominal one"
        );
        // A Hayati tilt on joint 3 as well (beta of a nominally parallel pair): the exported
        // origins must carry it too.
        let mut model = model;
        model.joints[2].beta_deg = Some(0.03);
        let model_path = d.join("model_tilted.toml");
        model.save(&model_path).unwrap();
        let exported = d.join("exported.urdf");
        export_urdf(&model_path, &path, &exported, extra);
        let text = std::fs::read_to_string(&exported).unwrap();
        let (base, _) = chain_links(&path, d, extra);
        let chain = RefChain::new(&text, &base, "kinecal_tool");
        let in_base = with_base(&model, &nominal);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let mut worst = 0.0f64;
        let mut worst_rad = 0.0f64;
        for _ in 0..300 {
            let q = random_q(&mut rng, &chain.limits());
            let t = chain.pose(&q);
            let (p, r) = library_pose(&in_base, &q);
            worst = worst.max((p - point_of(&t, [0.0; 3])).norm());
            worst_rad = worst_rad.max(angle_between(&r, &rotation_of(&t)));
        }
        eprintln!(
            "{file}: exported calibrated URDF vs identified model: worst {worst:.3e} mm, \
             {worst_rad:.3e} rad"
        );
        assert!(worst < 1e-6, "{file}: {worst} mm");
        assert!(worst_rad < 1e-8, "{file}: {worst_rad} rad");
    }
}

/// The text without the `xyz`/`rpy` values of `<origin>` lines and without the appended tool
/// block: what export must leave byte for byte.
fn untouched_part(text: &str) -> (Vec<String>, usize) {
    let kept = match text.find("  <!-- kinecal: the calibrated tool point") {
        Some(cut) => format!(
            "{}{}",
            &text[..cut],
            &text[text.rfind("</robot>").unwrap()..]
        ),
        None => text.to_string(),
    };
    let mut origins = 0;
    let lines = kept
        .lines()
        .map(|l| {
            if l.trim_start().starts_with("<origin ") {
                origins += 1;
                let mut out = String::new();
                let mut inside = false;
                for c in l.chars() {
                    if c == '"' {
                        inside = !inside;
                        out.push(c);
                    } else if !inside {
                        out.push(c);
                    }
                }
                out
            } else {
                l.to_string()
            }
        })
        .collect();
    (lines, origins)
}

#[test]
fn export_leaves_everything_else_untouched() {
    for (folder, file, extra) in URDFS {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let path = urdf_path(folder, file);
        let (robot_path, mut model) = import(d, &path, extra);
        let original = std::fs::read_to_string(&path).unwrap();
        // A changed model: every length and angle moved a little, a tool point added.
        for j in &mut model.joints {
            j.a_mm += 0.3;
            j.d_mm -= 0.2;
            j.theta_deg += 0.05;
            j.alpha_deg -= 0.04;
        }
        model.tool.xyz_mm[2] += 5.0;
        let model_path = d.join("model.toml");
        model.save(&model_path).unwrap();
        let exported = d.join("out.urdf");
        export_urdf(&model_path, &path, &exported, extra);
        let text = std::fs::read_to_string(&exported).unwrap();
        assert!(text.contains(r#"<link name="kinecal_tool"/>"#));
        // Exporting into an exported file again would give two kinecal_tool links: refused.
        let (_, tip) = chain_links(&path, d, extra);
        let again = d.join("again.urdf");
        let o = kinecal(&[
            "export",
            "--model",
            s(&model_path),
            "--urdf",
            s(&exported),
            "--tip-link",
            &tip,
            "--out",
            s(&again),
        ]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("already has a link 'kinecal_tool'"),
            "{}",
            stderr(&o)
        );
        let (a, n_a) = untouched_part(&original);
        let (b, n_b) = untouched_part(&text);
        assert_eq!(n_a, n_b, "{file}");
        let first = a.iter().zip(&b).position(|(x, y)| x != y);
        if let Some(k) = first {
            panic!("{file}: line {} changed: {:?} -> {:?}", k + 1, a[k], b[k]);
        }
        assert_eq!(
            a.len(),
            b.len(),
            "{file}: only origin values and the tool block may change"
        );
        // Lines that changed: only origins, one per chain joint at most.
        let cut = text
            .find("  <!-- kinecal: the calibrated tool point")
            .unwrap();
        let without_tool = format!(
            "{}{}",
            &text[..cut],
            &text[text.rfind("</robot>").unwrap()..]
        );
        assert_eq!(original.lines().count(), without_tool.lines().count());
        let changed = original
            .lines()
            .zip(without_tool.lines())
            .filter(|(x, y)| x != y)
            .count();
        assert!(
            changed <= model.joints.len(),
            "{file}: {changed} lines changed"
        );
        // The nominal model exported gives back the original origins' numbers.
        let same = d.join("same.urdf");
        let mut args = vec![
            "export",
            "--model",
            s(&robot_path),
            "--urdf",
            s(&path),
            "--out",
            s(&same),
        ];
        args.extend_from_slice(extra);
        kinecal_ok(&args);
        let ours = urdf_rs::read_from_string(&std::fs::read_to_string(&same).unwrap()).unwrap();
        let theirs = urdf_rs::read_from_string(&original).unwrap();
        for j in &theirs.joints {
            let k = ours.joints.iter().find(|k| k.name == j.name).unwrap();
            let dt = (origin(&j.origin) - origin(&k.origin)).abs().max();
            assert!(dt < 1e-9, "{file}: joint {} origin moved by {dt}", j.name);
        }
    }
}
