//! A URDF's robot measured by a tracker in its own frame: `import` writes no `[base]`, the
//! data are simulated with the robot far from the tracker's origin, `identify` estimates the
//! base and the geometry, and `export` writes that model back into the URDF; the exported
//! URDF, imported again, has the identified kinematics. For each of the five public URDFs.

use crate::common::{json_of, kinecal, kinecal_ok, s, simulate, stderr};
use kinecal::ForwardKinematics;
use kinecal_cli::formats::robot_file::{BaseSpec, RobotFile};
use kinecal_cli::with_joints;
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::{Path, PathBuf};

/// (folder, file, chain options of import and export).
const URDFS: [(&str, &str, &[&str]); 5] = [
    ("abb_irb140", "irb140.urdf", &[]),
    ("kuka_kr16_2", "kr16_2.urdf", &[]),
    ("kuka_lbr_iiwa_14", "lbr_iiwa_14_r820.urdf", &[]),
    ("franka_panda", "panda_arm.urdf", &[]),
    ("ur10", "ur10_robot.urdf", &["--tip-link", "tool0"]),
];

/// Where the tracker sees the robot: metres from its origin, turned by tens of degrees.
const TRACKER_BASE: BaseSpec = BaseSpec {
    xyz_mm: [2400.0, -1300.0, 650.0],
    rpy_deg: [4.0, -3.0, 37.0],
};

fn urdf_path(dir: &str, file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/urdf")
        .join(dir)
        .join(file)
}

/// Tool points of `file` at the joint angles `qs` (degrees), in its base's frame.
fn points(file: &RobotFile, qs: &[Vec<f64>]) -> Vec<Vector3<f64>> {
    let r: anyhow::Result<Vec<Vector3<f64>>> = with_joints!(file.joints.len(), N => {
        let robot = file.to_robot::<N>().unwrap();
        let mut fk = ForwardKinematics::<f64, N>::new();
        Ok(qs
            .iter()
            .map(|q| {
                let mut qa = [0.0; N];
                for (a, d) in qa.iter_mut().zip(q) {
                    *a = d.to_radians();
                }
                fk.compute(&robot, &qa)
            })
            .collect())
    });
    r.unwrap()
}

/// The largest difference of the distances between any two of the points: zero when one set
/// is the other moved rigidly (the base is where each model was seen from, not the robot).
fn shape_difference_mm(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..a.len() {
        for j in i + 1..a.len() {
            worst = worst.max(((a[i] - a[j]).norm() - (b[i] - b[j]).norm()).abs());
        }
    }
    worst
}

#[test]
fn an_import_calibrated_in_a_tracker_frame_exports_back_into_its_urdf() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(30);
    for (folder, file, chain) in URDFS {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let urdf = urdf_path(folder, file);
        let robot = d.join("robot.toml");
        let mut args = vec!["import", "--urdf", s(&urdf), "--out", s(&robot)];
        args.extend_from_slice(chain);
        kinecal_ok(&args);
        let nominal = RobotFile::load(&robot).unwrap();
        assert!(nominal.base.is_none(), "{folder}: import wrote a [base]");
        // The robot in the tracker's frame, with geometry errors, measured.
        let mut placed = nominal.clone();
        placed.base = Some(TRACKER_BASE);
        let placed_path = d.join("placed.toml");
        std::fs::write(&placed_path, placed.to_toml().unwrap()).unwrap();
        let data = d.join("data.csv");
        simulate(
            &placed_path,
            Some(80),
            Some(0.005),
            Some(11),
            &["--geom-errors"],
            &data,
        );
        // check estimates the base: the import states none.
        let c = json_of(&kinecal_ok(&[
            "check",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--json",
        ]));
        assert_eq!(c["base_fitted"], true, "{folder}: {c}");
        let model = d.join("model.toml");
        let o = kinecal(&[
            "identify",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--out",
            s(&model),
            "--json",
        ]);
        let rep = json_of(&o);
        assert!(o.status.success(), "{folder}: {}", stderr(&o));
        let after = rep["after"]["identification_rms_mm"].as_f64().unwrap();
        assert!(after < 0.02, "{folder}: identified to {after} mm");
        let exported = d.join("exported.urdf");
        let mut args = vec![
            "export",
            "--model",
            s(&model),
            "--urdf",
            s(&urdf),
            "--out",
            s(&exported),
        ];
        args.extend_from_slice(chain);
        let o = kinecal(&args);
        assert!(o.status.success(), "{folder}: export: {}", stderr(&o));
        // Imported again up to the appended tool link: the identified kinematics.
        let again = d.join("again.toml");
        kinecal_ok(&[
            "import",
            "--urdf",
            s(&exported),
            "--tip-link",
            "kinecal_tool",
            "--out",
            s(&again),
        ]);
        let identified = RobotFile::load(&model).unwrap();
        let reimported = RobotFile::load(&again).unwrap();
        let qs: Vec<Vec<f64>> = (0..25)
            .map(|_| {
                identified
                    .joints
                    .iter()
                    .map(|j| {
                        let [lo, hi] = j.limits_deg.unwrap_or([-180.0, 180.0]);
                        rng.random_range(lo.max(-170.0)..=hi.min(170.0))
                    })
                    .collect()
            })
            .collect();
        let diff = shape_difference_mm(&points(&identified, &qs), &points(&reimported, &qs));
        eprintln!("{folder}: exported and re-imported within {diff:.2e} mm of the identified");
        assert!(diff < 1e-6, "{folder}: {diff} mm");
        // And that is not the nominal: the calibration went into the file.
        let moved = shape_difference_mm(&points(&nominal, &qs), &points(&reimported, &qs));
        assert!(
            moved > 0.05,
            "{folder}: the export equals the nominal ({moved} mm)"
        );
    }
}
