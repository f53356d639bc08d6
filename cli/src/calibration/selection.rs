//! Which parameters a fit estimates: `--only`, `--free` and `--fix` by the names `identify`
//! prints (`theta2`, `base.rz`, `tool2.x`, `joint-table1[0]`, `joint-cyclic3.n1.a`) and by
//! group (docs/formats.md "Parameter names and groups"):
//!
//! | group | parameters |
//! |---|---|
//! | `base` | `base.x` … `base.rz` |
//! | `tool` | every tool point coordinate and, when estimated, the tool orientation |
//! | `geometry` | every joint row: `alpha`, `a`, `theta`, `d` (and `beta` where it is a parameter) |
//! | `theta`, `alpha`, `a`, `d`, `beta` | that column of every row |
//! | `effects` | every effect value |
//! | `joint-tableN`, `joint-cyclicN`, `joint-scaleN`, `joint-complianceN` | every value of that effect of joint N |
//!
//! `--only` replaces the parameter list by what it names (also parameters the default list
//! leaves out, such as a base the robot file gives); `--free` then adds, `--fix` removes.

use kinecal::model::param::Param;
use kinecal::Robot;

/// The groups, as listed in messages.
const GROUPS: &str = "base, tool, geometry, theta, alpha, a, d, beta, effects, joint-tableN, \
                      joint-cyclicN, joint-scaleN, joint-complianceN, base-drift";

/// `--fix`, `--free`, `--only` and `--prior` on the command line (`identify`, and `report`
/// given what identify was given).
#[derive(clap::Args, Debug, Clone, Default, PartialEq)]
pub struct ParameterArgs {
    /// Hold these parameters at their file values: names as printed (d6, theta1, tool.z,
    /// base.rz, joint-table1[0], …) or groups (base, tool, geometry, theta, effects,
    /// joint-table2, …). Repeatable, or comma-separated.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub fix: Vec<String>,
    /// Estimate these parameters too (for example base when `[base]` is given but not
    /// trusted, or beta3 for a tilt); names or groups as for --fix.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub free: Vec<String>,
    /// Estimate only these parameters (names or groups as for --fix) and hold everything
    /// else: a quick re-calibration (`--only base,theta2,theta3` after a re-mastering).
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub only: Vec<String>,
    /// The prior on every parameter's change: `off`, or KIND=SIGMA over the robot file's
    /// `[prior]` and the defaults (length_mm 5, angle_deg 0.5, tool_mm 10, tool_deg 2,
    /// base_mm 10, base_deg 1, effect 0 = off). Comma-separated.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub prior: Vec<String>,
}

impl ParameterArgs {
    /// The selection these flags make.
    pub fn selection(&self) -> Selection<'_> {
        Selection {
            only: &self.only,
            free: &self.free,
            fix: &self.fix,
        }
    }
}

/// `--only`, `--free`, `--fix`, as given (each entry one name or group).
#[derive(Clone, Copy, Debug, Default)]
pub struct Selection<'a> {
    pub only: &'a [String],
    pub free: &'a [String],
    pub fix: &'a [String],
}

impl Selection<'_> {
    /// Nothing asked: the default list stands.
    pub fn is_empty(&self) -> bool {
        self.only.is_empty() && self.free.is_empty() && self.fix.is_empty()
    }
}

/// Every parameter a name can refer to for `robot`: the default list `params` and everything
/// else the model has (its base, rows, tilts, tool points and orientation, effect values).
fn universe<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    params: &[Param],
) -> Vec<Param> {
    let mut all: Vec<Param> = params.to_vec();
    let mut push = |p: Param| {
        if !all.contains(&p) {
            all.push(p);
        }
    };
    for p in Param::BASE {
        push(p);
    }
    for j in 0..N as u8 {
        for p in [Param::Alpha(j), Param::A(j), Param::Theta(j), Param::D(j)] {
            push(p);
        }
    }
    for p in [Param::ToolX, Param::ToolY, Param::ToolZ] {
        push(p);
    }
    for k in 1..robot.tool_point_count() {
        for a in 0..3 {
            push(Param::ToolPoint(k as u8, a));
        }
    }
    if !robot.tool_axes_identity() {
        for p in [Param::ToolRx, Param::ToolRy, Param::ToolRz] {
            push(p);
        }
    }
    for k in 0..robot.effects().values().len() {
        push(Param::Effect(k as u16));
    }
    all
}

/// What one name or group refers to among `all` (in `all`'s order); a single geometric name
/// that the model does not list yet (`beta3`, `tool.rx`) is taken as it parses. Refused
/// (exit 2) with the names this robot has when it refers to nothing.
fn resolve<const N: usize, V: kinecal::ValueStorage>(
    flag: &str,
    name: &str,
    robot: &Robot<f64, N, V>,
    all: &[Param],
) -> anyhow::Result<Vec<Param>> {
    let name = name.trim();
    let column = |f: fn(Param) -> bool| all.iter().copied().filter(|p| f(*p)).collect();
    let found: Vec<Param> = match name {
        "base" => column(Param::is_base),
        "tool" => column(|p| p.is_tool() || p.is_tool_rotation()),
        "geometry" => column(|p| p.joint().is_some()),
        "theta" => column(|p| matches!(p, Param::Theta(_))),
        "alpha" => column(|p| matches!(p, Param::Alpha(_))),
        "a" => column(|p| matches!(p, Param::A(_))),
        "d" => column(|p| matches!(p, Param::D(_))),
        "beta" => column(|p| matches!(p, Param::Beta(_))),
        "effects" => column(|p| matches!(p, Param::Effect(_))),
        // The drift acts on no joint: its group has no joint number.
        "base-drift" => effect_group("base-drift1", robot).unwrap_or_default(),
        _ => {
            let by_name: Vec<Param> = all
                .iter()
                .copied()
                .filter(|p| p.name(robot).to_string() == name)
                .collect();
            if !by_name.is_empty() {
                by_name
            } else if let Some(group) = effect_group(name, robot) {
                group
            } else {
                Param::parse(name)
                    .filter(|p| p.joint().is_none_or(|j| j < N))
                    .filter(|p| {
                        p.tool_point()
                            .is_none_or(|(k, _)| k < robot.tool_point_count())
                    })
                    .into_iter()
                    .collect()
            }
        }
    };
    if found.is_empty() {
        crate::refuse!(
            "{flag} {name}: not a parameter of this {N}-joint model (names as identify \
             prints them: base.x … base.rz, alpha1, a1, theta1, d1, beta1 … d{N}, \
             tool.x, tool.y, tool.z, effect values such as joint-table2[0]; groups: {GROUPS})"
        );
    }
    Ok(found)
}

/// Every value of the effect `KINDJ` (`joint-table2`, `joint-cyclic3`) of `robot`, if it has
/// one of that kind on that joint.
fn effect_group<const N: usize, V: kinecal::ValueStorage>(
    name: &str,
    robot: &Robot<f64, N, V>,
) -> Option<Vec<Param>> {
    let split = name.find(|c: char| c.is_ascii_digit())?;
    let (kind, joint) = name.split_at(split);
    let joint: usize = joint.parse().ok()?;
    let kind = kinecal::EffectKind::from_id(kind)?;
    let values: Vec<Param> = robot
        .effects()
        .iter()
        .filter(|e| e.kind == kind && e.joint as usize + 1 == joint)
        .flat_map(|e| e.range().map(|k| Param::Effect(k as u16)))
        .collect();
    (!values.is_empty()).then_some(values)
}

/// The parameters `names` (names or groups) refer to among everything `robot` has, in the
/// order given, each once (`plan --estimate`); refused (exit 2) naming `flag` and the first
/// name that refers to nothing.
pub fn named<const N: usize, V: kinecal::ValueStorage>(
    flag: &str,
    names: &[String],
    robot: &Robot<f64, N, V>,
) -> anyhow::Result<Vec<Param>> {
    let all = universe(robot, &[]);
    let mut out: Vec<Param> = Vec::new();
    for n in names {
        for p in resolve(flag, n, robot, &all)? {
            if !out.contains(&p) {
                out.push(p);
            }
        }
    }
    Ok(out)
}

/// Applies `sel` to the parameter list of a fit of `robot`: `--only` replaces it, `--free`
/// adds, `--fix` removes (each by name or group); the order stays that of the model.
pub fn apply<const N: usize, V: kinecal::ValueStorage>(
    params: &mut Vec<Param>,
    robot: &Robot<f64, N, V>,
    sel: &Selection<'_>,
) -> anyhow::Result<()> {
    if sel.is_empty() {
        return Ok(());
    }
    let all = universe(robot, params);
    let names = |flag: &str, list: &[String]| -> anyhow::Result<Vec<Param>> {
        let mut out = Vec::new();
        for n in list {
            out.extend(resolve(flag, n, robot, &all)?);
        }
        Ok(out)
    };
    let only = names("--only", sel.only)?;
    let free = names("--free", sel.free)?;
    let fix = names("--fix", sel.fix)?;
    let mut chosen: Vec<Param> = if sel.only.is_empty() {
        params.clone()
    } else {
        Vec::new()
    };
    chosen.extend(only);
    chosen.extend(free);
    chosen.retain(|p| !fix.contains(p));
    // The model's order (base, rows, tool, tilts, effects), then what only parsed.
    let mut ordered: Vec<Param> = all.iter().copied().filter(|p| chosen.contains(p)).collect();
    for p in chosen {
        if !ordered.contains(&p) {
            ordered.push(p);
        }
    }
    if ordered.is_empty() {
        crate::refuse!(
            "--only/--fix leave no parameter to estimate: name at least one parameter to fit"
        );
    }
    *params = ordered;
    Ok(())
}

/// With the base estimated: the base is a rigid transform before row 1, which row 1's
/// constant part only repeats (T_1(q) = Rx(alpha)·Tx(a)·Ry(beta)·Rz(theta)·Tz(d)·Rz(q)), so
/// alpha1, a1, beta1, theta1 and d1 are held at their file values and the base takes what they
/// would. Row 1 stays the robot's own (an import exports back into its URDF) and the
/// tracker's frame stays in the base. `--free` estimates them anyway.
pub fn hold_first_row(params: &mut Vec<kinecal::Param>) {
    params.retain(|p| {
        !matches!(
            p,
            kinecal::Param::Alpha(0)
                | kinecal::Param::A(0)
                | kinecal::Param::Beta(0)
                | kinecal::Param::Theta(0)
                | kinecal::Param::D(0)
        )
    });
}
