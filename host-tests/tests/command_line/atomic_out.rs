//! Output files are written atomically (`kinecal_cli::output::atomic::write_atomic`): whatever
//! happens to the writer — an error halfway through, `kill -9` at any moment — the target is
//! the previous complete file or the complete new one, never a torn one.

use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::output::atomic::write_atomic;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Instant;

use crate::common::{args_with_out, bin, kinecal, kinecal_ok, s, simulate, write, ER20_PLACED};

/// Files in `dir` other than hidden ones (an interrupted write may leave its hidden
/// temporary file behind; it never takes the target's name).
fn visible(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    v.sort();
    v
}

#[test]
fn write_atomic_replaces_whole_files_and_leaves_nothing_on_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("out.csv");
    write_atomic(&p, b"first\n").unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), b"first\n");
    let big = vec![b'x'; 1 << 20];
    write_atomic(&p, &big).unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), big);
    // No temporary file is left behind after a successful write.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // A directory where the file should go: refused, the directory untouched, no leftovers.
    let d = dir.path().join("sub");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(d.join("keep"), b"k").unwrap();
    assert!(write_atomic(&d, b"new").is_err());
    assert_eq!(std::fs::read(d.join("keep")).unwrap(), b"k");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    // A missing directory: an error, nothing created.
    assert!(write_atomic(&dir.path().join("none/out.csv"), b"x").is_err());
    assert!(!dir.path().join("none").exists());
    // A path that names no file.
    assert!(write_atomic(Path::new("/"), b"x").is_err());
}

/// The writer fails halfway: `identify --out` under a 1 KiB file-size limit (`ulimit -f 1`)
/// cannot write its ~2 KiB model. The previous model must stay whole. (A plain write under the
/// same limit leaves a torn file: the control below shows the limit bites.)
#[test]
fn a_write_that_fails_halfway_keeps_the_previous_file() {
    let dir = tempfile::tempdir().unwrap();
    // A long name makes the model file larger than the limit.
    let text = ER20_PLACED.replacen(
        "ER20-C10-like 6R",
        &format!("ER20-C10-like 6R {}", "x".repeat(1500)),
        1,
    );
    let robot = write(dir.path(), "r.toml", &text);
    let data = dir.path().join("d.csv");
    simulate(
        &robot,
        Some(60),
        Some(0.01),
        None,
        &["--geom-errors"],
        &data,
    );
    let model = dir.path().join("m.toml");
    kinecal_ok(&args_with_out("identify", &robot, &data, &model));
    let new_text = std::fs::read_to_string(&model).unwrap();
    assert!(
        new_text.len() > 2048,
        "the model must exceed the limit: {} bytes",
        new_text.len()
    );

    let previous = "name = \"previous model\"\n# a complete file that must survive\n";
    std::fs::write(&model, previous).unwrap();
    let cmd = format!(
        "ulimit -f 1; exec '{}' identify --robot '{}' --data '{}' --out '{}'",
        bin(),
        s(&robot),
        s(&data),
        s(&model)
    );
    let o = Command::new("bash").args(["-c", &cmd]).output().unwrap();
    assert!(!o.status.success(), "the write must fail under the limit");
    assert_eq!(std::fs::read_to_string(&model).unwrap(), previous);
    assert_eq!(visible(dir.path()), vec!["d.csv", "m.toml", "r.toml"]);

    // Control: the same limit tears a plain (non-atomic) write of the new model.
    let src = dir.path().join("new.toml");
    std::fs::write(&src, &new_text).unwrap();
    let torn = dir.path().join("torn.toml");
    std::fs::write(&torn, previous).unwrap();
    let cmd = format!("ulimit -f 1; cat '{}' > '{}'", s(&src), s(&torn));
    let _ = Command::new("bash").args(["-c", &cmd]).output().unwrap();
    let t = std::fs::read_to_string(&torn).unwrap();
    assert!(t != previous && t != new_text, "a plain write is torn");
}

/// `kill -9` at random moments of `identify --out M.toml` on a large data set: M.toml is always
/// the previous complete model or the complete new one.
#[test]
fn kill_9_during_identify_never_leaves_a_torn_model() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "r.toml", ER20_PLACED);
    let data = dir.path().join("big.csv");
    simulate(
        &robot,
        Some(30000),
        Some(0.01),
        None,
        &["--geom-errors"],
        &data,
    );
    let model = dir.path().join("M.toml");
    let identify = || {
        Command::new(bin())
            .args(args_with_out("identify", &robot, &data, &model))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    // The complete new model, and how long a run takes.
    let t0 = Instant::now();
    assert!(identify().wait().unwrap().success());
    let full = t0.elapsed();
    let new_text = std::fs::read_to_string(&model).unwrap();
    let new_file = RobotFile::parse(&new_text, "M.toml").unwrap();
    assert!(new_file.name.contains("identified"));

    let previous = RobotFile::parse(ER20_PLACED, "r.toml")
        .unwrap()
        .to_toml()
        .unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
    let (mut kept, mut replaced) = (0, 0);
    for round in 0..40 {
        std::fs::write(&model, &previous).unwrap();
        let mut child = identify();
        // Most kills land in the computation; the last fifth of the window is the write.
        let f: f64 = rng.random_range(0.0..1.2);
        std::thread::sleep(full.mul_f64(f));
        let _ = child.kill(); // SIGKILL
        let _ = child.wait();
        let now = std::fs::read_to_string(&model).unwrap();
        let parsed = RobotFile::parse(&now, "M.toml")
            .unwrap_or_else(|e| panic!("round {round}: torn model ({e}):\n{now}"));
        if now == previous {
            kept += 1;
        } else {
            assert_eq!(
                now, new_text,
                "round {round}: neither the old nor the new model"
            );
            assert_eq!(parsed, new_file);
            replaced += 1;
        }
        assert!(visible(dir.path())
            .iter()
            .all(|n| ["M.toml", "big.csv", "r.toml"].contains(&n.as_str())));
    }
    assert!(
        kept > 0,
        "some kills must land before the write ({kept} kept, {replaced} replaced)"
    );
}

/// `--out` naming one of the command's inputs is refused (exit 2) before anything is written:
/// `identify --data D --out D` used to destroy the measurements it had just read.
#[test]
fn out_never_overwrites_an_input() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "r.toml", ER20_PLACED);
    let data = dir.path().join("d.csv");
    simulate(&robot, Some(40), Some(0.01), None, &[], &data);
    let targets = dir.path().join("t.csv");
    std::fs::copy(&data, &targets).unwrap();
    let before_robot = std::fs::read(&robot).unwrap();
    let before_data = std::fs::read(&data).unwrap();
    // The same file through another spelling of its path counts too.
    let data_alias = dir.path().join(".").join("d.csv");
    let cases: Vec<Vec<&str>> = vec![
        args_with_out("identify", &robot, &data, &data_alias),
        args_with_out("identify", &robot, &data, &robot),
        args_with_out("diagnose", &robot, &data, &data),
        args_with_out("compensate", &robot, &targets, &robot),
        args_with_out("compensate", &robot, &targets, &targets),
    ];
    for args in cases {
        let out = kinecal(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("never writes over its inputs"), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    }
    assert_eq!(std::fs::read(&robot).unwrap(), before_robot);
    assert_eq!(std::fs::read(&data).unwrap(), before_data);
}
