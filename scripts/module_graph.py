#!/usr/bin/env python3
"""The module graph of kinecal: which module uses which, drawn with the layers as folders.

Reads the Rust sources of the library (`src/`) and of the command line (`cli/src/`), collects
every path a module uses (`crate::a::b`, `kinecal::a::b`, `super::b`, and the crate-root
re-exports such as `kinecal::Robot`), and checks the architecture that `src/lib.rs` and
`cli/src/lib.rs` document:

- no import circle between folders (layers) or between files;
- each library layer uses only the layers listed before it in `LIBRARY_LAYERS`;
- each command-line layer uses only the layers listed before it in `CLI_LAYERS` (and the
  library);
- no Rust source file in the workspace is longer than `MAX_LINES` lines (a longer file holds
  several concepts: split it).

Usage: python3 scripts/module_graph.py [--svg-dir docs]
Exit status 1 and a message naming the edge when a rule is broken. `--svg` needs Graphviz.
"""
import argparse
import os
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent

# Bottom to top, as src/lib.rs lists them.
LIBRARY_LAYERS = ["num", "model", "forward", "io", "identify", "compensate", "frames", "planning"]
# Bottom to top, as cli/src/lib.rs lists them (lib.rs itself holds the error types and macros).
CLI_LAYERS = ["lib", "output", "compute", "formats", "simulation", "calibration", "diagnose",
              "plan", "reports", "constraints", "report_html", "application", "frames", "compensation", "commands", "main"]

# The longest a Rust source file may be, tests included.
MAX_LINES = 800
# Folders of the workspace that hold no source of ours.
NOT_SOURCE = {"target", ".git", "node_modules"}

# Crate-root re-exports of the library and the file that defines each.
ROOT_REEXPORTS = {
    "CouplingError": "model/coupling", "Couplings": "model/coupling",
    "Effect": "model/effects", "EffectKind": "model/effects", "Effects": "model/effects",
    "ForwardKinematics": "forward", "Frame": "model/frame", "Measurement": "io/measurement",
    "Param": "model/param", "ParamSet": "model/param", "Real": "num/real",
    "Joint": "model/robot", "Robot": "model/robot", "RobotError": "model/robot",
}


def module_of(base, path):
    """`model/robot` for src/model/robot.rs, `model` for src/model/mod.rs, `lib` for lib.rs."""
    rel = path.relative_to(base).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "mod":
        parts = parts[:-1]
    return "/".join(parts)


def strip_comments(text):
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return "\n".join(line.split("//")[0] for line in text.split("\n"))


def strip_tests(text):
    """Drops `#[cfg(test)] mod tests { … }` blocks: unit tests may use anything."""
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*mod\s+\w+\s*\{", text):
        if m.start() < i:
            continue
        out.append(text[i:m.start()])
        depth, j = 1, m.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    out.append(text[i:])
    return "".join(out)


def resolve(modules, current, segs):
    """The longest known module named by the path segments `segs` (relative to the crate)."""
    for k in range(len(segs), 0, -1):
        cand = "/".join(segs[:k])
        if cand in modules:
            return cand
    return None


def expand_use_groups(text):
    """`a::{b, c::d}` → `a::b a::c::d` (one level of braces, enough for this code base)."""
    def repl(m):
        prefix, inner = m.group(1), m.group(2)
        return " ".join(prefix + "::" + p.strip() for p in inner.split(",") if p.strip())
    prev = None
    while prev != text:
        prev = text
        text = re.sub(r"((?:\w+::)*\w+)::\{([^{}]*)\}", repl, text)
    return text


def edges_of(base, crate_name, own_prefixes):
    modules = {}
    for path in sorted(base.rglob("*.rs")):
        modules[module_of(base, path)] = path
    edges = set()
    for mod, path in modules.items():
        text = expand_use_groups(strip_tests(strip_comments(path.read_text())))
        parent = mod.rsplit("/", 1)[0] if "/" in mod else ""
        for m in re.finditer(r"\b(crate|super|self|kinecal|kinecal_cli)((?:::\w+)+)", text):
            head, segs = m.group(1), m.group(2).split("::")[1:]
            if head in own_prefixes:
                base_segs = []
            elif head == "super":
                base_segs = [s for s in parent.split("/") if s]
            elif head == "self":
                base_segs = [s for s in mod.split("/") if s]
            else:
                continue
            segs = base_segs + segs
            target = resolve(modules, mod, segs)
            if target is None and segs and segs[0] in ROOT_REEXPORTS and crate_name == "kinecal":
                target = ROOT_REEXPORTS[segs[0]]
            if target and target != mod and not mod.startswith(target + "/") and target != "lib":
                edges.add((mod, target))
    return set(modules), edges


def layer(mod, layers):
    top = mod.split("/")[0]
    return top if top in layers else None


def find_cycle(nodes, edges):
    graph = {n: sorted(t for s, t in edges if s == n) for n in nodes}
    state, stack = {}, []

    def visit(n):
        state[n] = 1
        stack.append(n)
        for t in graph.get(n, []):
            if state.get(t) == 1:
                return stack[stack.index(t):] + [t]
            if not state.get(t):
                c = visit(t)
                if c:
                    return c
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(nodes):
        if not state.get(n):
            c = visit(n)
            if c:
                return c
    return None


def check(name, nodes, edges, layers):
    problems = []
    c = find_cycle(nodes, edges)
    if c:
        problems.append(f"{name}: import circle between files: {' -> '.join(c)}")
    ledges = {(layer(s, layers), layer(t, layers)) for s, t in edges}
    ledges = {(a, b) for a, b in ledges if a and b and a != b}
    c = find_cycle(set(layers), ledges)
    if c:
        problems.append(f"{name}: import circle between folders: {' -> '.join(c)}")
    for s, t in sorted(edges):
        ls, lt = layer(s, layers), layer(t, layers)
        if ls and lt and ls != lt and layers.index(lt) > layers.index(ls):
            problems.append(f"{name}: {s} uses {t}, a layer above it ({ls} < {lt} in the layer order)")
    unknown = sorted({s.split('/')[0] for s in nodes if layer(s, layers) is None})
    if unknown:
        problems.append(f"{name}: modules outside the documented layers: {', '.join(unknown)}")
    return problems


def dot_layers(title, edges, layers):
    """Folder-level drawing: one box per layer, bottom to top, an arrow per pair of layers."""
    counts = {}
    for src, dst in edges:
        a, b = layer(src, layers), layer(dst, layers)
        if a and b and a != b:
            counts[(a, b)] = counts.get((a, b), 0) + 1
    used = sorted({x for pair in counts for x in pair}, key=layers.index)
    out = [f'digraph "{title}" {{', '  rankdir=BT; nodesep=0.3; ranksep=0.35;',
           f'  label="{title}: folders, bottom to top; an arrow = uses (number of file-to-file uses)";',
           '  labelloc=t; fontname="Helvetica"; fontsize=11;',
           '  node [shape=folder, fontname="Helvetica", fontsize=11, style=filled, fillcolor="#eef3fb"];',
           '  edge [fontname="Helvetica", fontsize=8, color="#00000060", arrowsize=0.6];']
    for lay in used:
        out.append(f'  "{lay}" [label="{lay}/"];' if lay not in ("forward", "lib", "main")
                   else f'  "{lay}" [label="{lay}.rs", shape=note];')
    for (a, b), n in sorted(counts.items()):
        out.append(f'  "{a}" -> "{b}" [label="{n}"];')
    out.append("}")
    return "\n".join(out) + "\n"


def dot_files(title, nodes, edges, layers):
    """File-level drawing: the files of each folder in a box, an arrow per use."""
    out = [f'digraph "{title}" {{', '  rankdir=BT; newrank=true; nodesep=0.15; ranksep=0.5;',
           f'  label="{title}: files in their folders; an arrow = uses"; labelloc=t;',
           '  fontname="Helvetica"; fontsize=11;',
           '  node [shape=box, fontname="Helvetica", fontsize=9, style=filled, fillcolor=white, height=0.25];',
           '  edge [color="#00000035", arrowsize=0.4];']
    linked = {x for e in edges for x in e}
    for lay in layers:
        members = sorted(n for n in nodes if layer(n, layers) == lay and (n in linked or "/" in n))
        if not members:
            continue
        out.append(f'  subgraph "cluster_{lay}" {{ label="{lay}/"; style="rounded,filled"; '
                   'fillcolor="#eef3fb"; color="#9fb3d9"; fontname="Helvetica-Bold"; fontsize=10;')
        for n in members:
            out.append(f'    "{n}" [label="{n.split("/")[-1]}"];')
        out.append("  }")
    for src, dst in sorted(edges):
        if src in nodes and dst in nodes:
            out.append(f'  "{src}" -> "{dst}";')
    out.append("}")
    return "\n".join(out) + "\n"


def render(text, path):
    svg = subprocess.run(["dot", "-Tsvg"], input=text, capture_output=True, text=True, check=True)
    path.write_text(svg.stdout)


def long_files():
    """Every Rust file of the workspace longer than `MAX_LINES` lines, as a problem."""
    problems = []
    for folder, subfolders, files in os.walk(ROOT):
        subfolders[:] = sorted(d for d in subfolders if d not in NOT_SOURCE)
        for name in sorted(f for f in files if f.endswith(".rs")):
            path = pathlib.Path(folder) / name
            lines = len(path.read_text(encoding="utf-8").splitlines())
            if lines > MAX_LINES:
                problems.append(f"{path.relative_to(ROOT)} has {lines} lines, over {MAX_LINES}: "
                                "split it by concept")
    return problems


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--svg-dir", type=pathlib.Path,
                    help="write module-graph-{library,cli}{,-files}.svg there (needs Graphviz)")
    a = ap.parse_args()
    lib_nodes, lib_edges = edges_of(ROOT / "src", "kinecal", {"crate"})
    cli_nodes, cli_edges = edges_of(ROOT / "cli" / "src", "kinecal_cli", {"crate", "kinecal_cli"})
    lib_nodes.discard("lib")
    cli_nodes.discard("lib")
    cli_edges = {(s, t) for s, t in cli_edges if "lib" not in (s, t)}
    problems = check("library", lib_nodes, lib_edges, LIBRARY_LAYERS)
    problems += check("cli", cli_nodes, cli_edges, CLI_LAYERS)
    problems += long_files()
    if a.svg_dir:
        a.svg_dir.mkdir(parents=True, exist_ok=True)
        for name, title, nodes, edges, layers in [
                ("library", "kinecal (src/)", lib_nodes, lib_edges, LIBRARY_LAYERS),
                ("cli", "kinecal-cli (cli/src/)", cli_nodes, cli_edges, CLI_LAYERS)]:
            render(dot_layers(title, edges, layers), a.svg_dir / f"module-graph-{name}.svg")
            render(dot_files(title, nodes, edges, layers), a.svg_dir / f"module-graph-{name}-files.svg")
    print(f"library: {len(lib_nodes)} modules, {len(lib_edges)} uses; "
          f"cli: {len(cli_nodes)} modules, {len(cli_edges)} uses")
    for p in problems:
        print("module graph:", p, file=sys.stderr)
    if problems:
        sys.exit(1)
    print("no import circle; every layer uses only the layers below it; "
          f"no Rust file over {MAX_LINES} lines")


if __name__ == "__main__":
    main()
