//! Every fenced example of docs/formats.md, taken from the file as it is and run through the
//! binary: robot file, couplings, prior and cell file accepted; the CSV accepted; the `--map`
//! command accepted; the documented messages printed word for word. An example added to the
//! page without a case here fails [`every_example_of_formats_md_runs`], so the page and the
//! tool cannot drift apart.

use crate::common::{data_file, kinecal, kinecal_ok, s, stderr, ur10_dir, write};
use std::path::{Path, PathBuf};

/// A fenced block: its language and its text (without the fences).
struct Block {
    lang: String,
    text: String,
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The fenced blocks of `text`, in order.
fn blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<Block> = None;
    for line in text.lines() {
        match (line.strip_prefix("```"), open.take()) {
            (Some(_), Some(b)) => out.push(b),
            (Some(lang), None) => {
                open = Some(Block {
                    lang: lang.trim().to_string(),
                    text: String::new(),
                })
            }
            (None, Some(mut b)) => {
                b.text.push_str(line);
                b.text.push('\n');
                open = Some(b);
            }
            (None, None) => {}
        }
    }
    assert!(open.is_none(), "an unclosed fence in docs/formats.md");
    out
}

/// The ER20 robot file of the tests with `more` appended.
fn er20_plus(dir: &Path, name: &str, more: &str) -> PathBuf {
    let text = std::fs::read_to_string(data_file("er20.toml")).unwrap();
    write(dir, name, &format!("{text}\n{more}"))
}

/// `simulate` accepts the robot file (it parses and validates it).
fn accepted_robot(robot: &Path, dir: &Path) {
    let out = dir.join("sim.csv");
    kinecal_ok(&[
        "simulate",
        "--robot",
        s(robot),
        "--poses",
        "8",
        "--out",
        s(&out),
    ]);
}

/// The documented message `doc` (one sentence broken over lines, after `kinecal: `) is what
/// the refusal `stderr` says, with `path` standing for the file the page names.
fn same_message(doc: &str, stderr: &str, named: &str, path: &str) {
    let doc = doc.split_whitespace().collect::<Vec<_>>().join(" ");
    let doc = doc
        .strip_prefix("kinecal: ")
        .unwrap_or(&doc)
        .replace(named, path);
    let got = stderr.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(got.contains(&doc), "documented:\n{doc}\nprinted:\n{got}");
}

/// The robot file of "Robot file": complete but for "five more [[joints]]" (the ER20's).
fn robot_file_example(b: &Block, dir: &Path) {
    let er20 = std::fs::read_to_string(data_file("er20.toml")).unwrap();
    // Joints 2 to 6 of the ER20: from its second [[joints]] to its [tool].
    let second = er20.match_indices("[[joints]]").nth(1).unwrap().0;
    let rows = &er20[second..er20.find("[tool]").unwrap()];
    let marker = "# … five more [[joints]] …";
    assert!(b.text.contains(marker), "{}", b.text);
    let robot = write(dir, "robot.toml", &b.text.replace(marker, rows));
    accepted_robot(&robot, dir);
}

/// The CSV of "Measurement CSV": the first rows of data/ur10/ur10_random_poses.csv with a
/// comment; read with the rest of that file, `check` accepts it.
fn csv_example(b: &Block, dir: &Path) {
    let real = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv")).unwrap();
    let rows: Vec<&str> = b
        .text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("q1"))
        .collect();
    let real_rows: Vec<&str> = real.lines().skip(1).collect();
    assert_eq!(
        rows,
        real_rows[..rows.len()],
        "the example is the file's first rows"
    );
    let mut text = b.text.clone();
    for r in &real_rows[rows.len()..] {
        text.push_str(r);
        text.push('\n');
    }
    let data = write(dir, "example.csv", &text);
    let robot = ur10_dir().join("robot.toml");
    let v = crate::common::json_of(&kinecal_ok(&[
        "check",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--json",
    ]));
    assert_eq!(v["poses"].as_u64().unwrap() as usize, real_rows.len());
}

/// The units refusal of "Units and the plausibility check": the UR10 file in metres.
fn metres_message(b: &Block, dir: &Path) {
    let real = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv")).unwrap();
    let mut lines = real.lines();
    let header = lines.next().unwrap();
    let cols: Vec<&str> = header.split(',').collect();
    let mut text = format!("{header}\n");
    for l in lines {
        let cells: Vec<String> = l
            .split(',')
            .zip(&cols)
            .map(|(c, name)| match *name {
                "x" | "y" | "z" => format!("{}", c.parse::<f64>().unwrap() / 1000.0),
                _ => c.to_string(),
            })
            .collect();
        text.push_str(&cells.join(","));
        text.push('\n');
    }
    let data = write(dir, "ur10_m.csv", &text);
    let robot = ur10_dir().join("robot.toml");
    let o = kinecal(&["check", "--robot", s(&robot), "--data", s(&data)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    same_message(&b.text, &stderr(&o), "ur10_m.csv", s(&data));
}

/// The map of "Files in other layouts": read as a map (its keys and values are kinecal's);
/// on the published excerpt it lacks only the columns it does not list.
fn map_example(b: &Block, dir: &Path) {
    let map = write(dir, "example.map.toml", &b.text);
    let root = repo_root();
    let o = kinecal(&[
        "check",
        "--robot",
        s(&root.join("data/ur10/robot.toml")),
        "--data",
        s(&root.join("data/ur10/published/measurements_random_poses_excerpt.csv")),
        "--map",
        s(&map),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("q2"),
        "only the unlisted columns are missing: {e}"
    );
}

/// A `sh` block: `kinecal …` commands (backslash continuations joined), run from the
/// repository root; each must succeed.
fn shell_example(b: &Block) {
    let joined = b.text.replace("\\\n", " ");
    let mut ran = 0;
    for line in joined
        .lines()
        .filter(|l| l.trim_start().starts_with("kinecal "))
    {
        let words: Vec<&str> = line.split_whitespace().skip(1).collect();
        let o = std::process::Command::new(crate::common::bin())
            .args(&words)
            .current_dir(repo_root())
            .output()
            .unwrap();
        assert!(o.status.success(), "{line}: {}", stderr(&o));
        ran += 1;
    }
    assert!(ran > 0, "no kinecal command in {}", b.text);
}

/// The convention refusal of "The convention check": the UR10 6-D file read with a map that
/// states the tracker's order.
fn convention_message(b: &Block, dir: &Path) {
    let map = write(dir, "M.toml", "[units]\nrotation = \"Rx*Ry*Rz\"\n");
    let root = repo_root();
    let data = root.join("data/ur10/ur10_random_poses_6d.csv");
    let o = kinecal(&[
        "check",
        "--robot",
        s(&root.join("data/ur10/robot.toml")),
        "--data",
        s(&data),
        "--map",
        s(&map),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    let doc = b.text.replace("M.toml", s(&map));
    same_message(&doc, &e, "data/ur10/ur10_random_poses_6d.csv", s(&data));
}

/// The warning of "Stale readings": `check` on the UR10 series B as published, from the
/// repository root (the file named as the command line names it).
fn stale_message(b: &Block, _: &Path) {
    let o = std::process::Command::new(crate::common::bin())
        .args([
            "check",
            "--robot",
            "data/ur10/robot.toml",
            "--data",
            "data/ur10/published/series_b/measurements_joint_configurations.csv",
            "--map",
            "data/ur10/published/ur10_positions.map.toml",
        ])
        .current_dir(repo_root())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    same_message(&b.text, &stderr(&o), "", "");
}

/// The cell file of "Cell file": `plan` reads it for the ER20.
fn cell_example(b: &Block, dir: &Path) {
    let cell = write(dir, "cell.toml", &b.text);
    let out = dir.join("plan.csv");
    let o = kinecal(&[
        "plan",
        "--robot",
        s(&data_file("er20.toml")),
        "--scene",
        s(&cell),
        "--poses",
        "10",
        "--criterion",
        "random",
        "--work=0,-30,30,0,30,0",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn every_example_of_formats_md_runs() {
    let page = std::fs::read_to_string(repo_root().join("docs/formats.md")).unwrap();
    let all = blocks(&page);
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut run = 0;
    for (k, b) in all.iter().enumerate() {
        let first = b.text.lines().next().unwrap_or("");
        let case = match (b.lang.as_str(), first) {
            ("toml", l) if l.starts_with("name = ") => robot_file_example as fn(&Block, &Path),
            ("toml", "[[couplings]]") => {
                |b: &Block, d: &Path| accepted_robot(&er20_plus(d, "coupled.toml", &b.text), d)
            }
            ("toml", l) if l.starts_with("[prior]") => {
                |b: &Block, d: &Path| accepted_robot(&er20_plus(d, "prior.toml", &b.text), d)
            }
            ("csv", _) => csv_example,
            ("text", l) if l.contains("look like metres") => metres_message,
            ("toml", l) if l.starts_with("delimiter = ") => map_example,
            ("sh", _) => |b: &Block, _: &Path| shell_example(b),
            ("text", l) if l.contains("orientation angles look composed") => convention_message,
            ("toml", l) if l.starts_with("[tracker]") => cell_example,
            ("text", l) if l.contains("row(s) repeat an") => stale_message,
            _ => panic!(
                "docs/formats.md example {} ({}, `{first}`) has no case here: add one",
                k + 1,
                b.lang
            ),
        };
        case(b, d);
        run += 1;
    }
    assert_eq!(run, all.len());
    assert!(run >= 9, "only {run} examples found");
}
