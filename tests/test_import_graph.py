"""The packages' import graph, read with `ast` (module-level AND function-level imports): no cycles, and no
arrow against the layering.

    spine_module            runs on the robot: never imports sparc_quad, the simulator, plotting or stats
    sparc_quad.robots       where the URDFs live: imports nothing of sparc_quad
    sparc_quad.effects      the effect library and plant file (below sim and gap): imports neither
    sparc_quad.sim          the worlds (physics, robots, spine drives): imports none of the layers above it
    sparc_quad.gaits        leg controllers (read a world): above sim
    sparc_quad.metrics      what a bound's log measures: above sim
    sparc_quad.bound        the run driver over world, gait, spine and metrics
    sparc_quad.robot_side   the robot's side of the spine interface (above sim)
    sparc_quad.scenario     one description of a run, and the translation into the driver's configuration
    sparc_quad.study, gap, experiments   tools over runs
    sparc_quad.cli          imports anything; nothing imports it

`test_packages_form_a_layered_graph` checks the same at package level: the graph of the packages has no
cycle.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("spine_module", "sparc_quad")
GENERATED = ("spine_module.messages.lcmt",)  # lcm-gen output, imports its own package by design


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            name = _module_name(path)
            if not name.startswith(GENERATED):
                out[name] = path
    return out


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or \
        (isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


def _imports(path: Path, name: str, is_pkg: bool) -> set[str]:
    """Every module `path` imports, wherever the import statement is (TYPE_CHECKING blocks excluded)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_type_checking(node):
            skip.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    found: set[str] = set()
    package = name if is_pkg else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                mod = ".".join([*base, node.module] if node.module else base)
            else:
                mod = node.module or ""
            for alias in node.names:  # `from pkg import submodule` imports the submodule; else pkg's name
                found.add(f"{mod}.{alias.name}" if f"{mod}.{alias.name}" in MODULES else mod)
    return found


MODULES = _modules()


def import_graph() -> dict[str, set[str]]:
    """module -> the project modules it imports, and "!name" for every other module it names."""
    mods = MODULES
    graph = {}
    for name, path in mods.items():
        names = _imports(path, name, path.name == "__init__.py")
        graph[name] = {n for n in names if n in mods and n != name}
        graph[name] |= {f"!{n}" for n in names if n not in mods}
    return graph


def _internal(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    return {m: {n for n in deps if not n.startswith("!")} for m, deps in graph.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan), each one a cycle."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


GRAPH = import_graph()


def _under(name: str, prefix: str) -> bool:
    return name == prefix or name.startswith(prefix + ".")


def _violations(src_prefix: str, forbidden: tuple[str, ...]) -> list[str]:
    bad = []
    for mod, deps in GRAPH.items():
        if not _under(mod, src_prefix):
            continue
        for dep in deps:
            target = dep.lstrip("!")
            if any(_under(target, f) for f in forbidden):
                bad.append(f"{mod} imports {target}")
    return sorted(bad)


def test_graph_sees_function_level_imports():
    """The reader finds an import inside a function body (the kind that hid the cycles)."""
    assert "sparc_quad.sim.robot_files" in GRAPH["sparc_quad.cli.robots"]


# Cycles and arrows that other open work removes; listed so that no NEW one can appear. A test below fails
# when a listed one is gone, so the list only shrinks.
KNOWN_CYCLES: list[list[str]] = []  # (i13's study.trial <-> raibert_opt cycle: fixed_trial split out)
KNOWN_ARROWS: set[str] = set()  # (i9-loop's sim.bench_robot -> bench arrows are gone)


def test_no_import_cycles():
    assert [c for c in _cycles(_internal(GRAPH)) if c not in KNOWN_CYCLES] == []


def test_known_exceptions_still_exist():
    """Remove an entry from KNOWN_* once its cycle or arrow is gone."""
    cycles = _cycles(_internal(GRAPH))
    assert [c for c in KNOWN_CYCLES if c not in cycles] == []
    arrows = set(_violations("sparc_quad.sim", ("sparc_quad.experiments",)))
    assert KNOWN_ARROWS - arrows == set()


@pytest.mark.parametrize(("layer", "forbidden"), [
    ("spine_module", ("sparc_quad", "pybullet", "pybullet_data", "mujoco", "matplotlib", "scipy",
                      "statsmodels", "tqdm", "example_robot_data", "cma", "dask")),
    ("sparc_quad.robots", ("sparc_quad.sim", "sparc_quad.experiments", "sparc_quad.gap", "sparc_quad.study",
                           "sparc_quad.cli", "sparc_quad.gaits")),
    ("sparc_quad.effects", ("sparc_quad.sim", "sparc_quad.gap", "sparc_quad.robot_side",
                            "sparc_quad.experiments", "sparc_quad.study", "sparc_quad.cli", "pybullet")),
    ("sparc_quad.sim", ("sparc_quad.robot_side", "sparc_quad.experiments", "sparc_quad.gap",
                        "sparc_quad.study", "sparc_quad.cli", "sparc_quad.gaits", "sparc_quad.metrics",
                        "sparc_quad.bound", "sparc_quad.scenario", "sparc_quad.api")),
    ("sparc_quad.gaits", ("sparc_quad.bound", "sparc_quad.metrics", "sparc_quad.scenario", "sparc_quad.study",
                          "sparc_quad.robot_side", "sparc_quad.api")),
    ("sparc_quad.metrics", ("sparc_quad.gaits", "sparc_quad.bound", "sparc_quad.scenario", "sparc_quad.study",
                            "sparc_quad.robot_side", "sparc_quad.api")),
    ("sparc_quad.bound", ("sparc_quad.scenario", "sparc_quad.study", "sparc_quad.cli", "sparc_quad.api",
                          "sparc_quad.gap", "sparc_quad.experiments")),
    ("sparc_quad.scenario", ("sparc_quad.study", "sparc_quad.cli", "sparc_quad.api", "sparc_quad.gap",
                             "sparc_quad.experiments")),
    ("sparc_quad.robot_side", ("sparc_quad.experiments", "sparc_quad.gap", "sparc_quad.study",
                               "sparc_quad.cli")),
    ("sparc_quad.experiments", ("sparc_quad.cli",)),
    ("sparc_quad.gap", ("sparc_quad.cli",)),
    ("sparc_quad.gaits", ("sparc_quad.cli",)),
    ("sparc_quad.study", ("sparc_quad.cli",)),
])
def test_layering(layer, forbidden):
    assert [v for v in _violations(layer, forbidden) if v not in KNOWN_ARROWS] == []


def test_cycle_detector_can_fail():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == [["a", "b", "c"]]


def _package(module: str) -> str:
    """The package a module belongs to: its first two dotted names (sparc_quad.sim), or the module itself
    for a top-level one (sparc_quad.api)."""
    parts = module.split(".")
    return ".".join(parts[:2])


def test_packages_form_a_layered_graph():
    """Module cycles aside, no two packages import each other through any chain: the folder layout is the
    architecture (sim below gaits below bound below scenario ...)."""
    packages: dict[str, set[str]] = {}
    for mod, deps in _internal(GRAPH).items():
        src = _package(mod)
        packages.setdefault(src, set()).update(_package(d) for d in deps if _package(d) != src)
    cycles = [c for c in _cycles(packages) if not all(p.startswith("spine_module") for p in c)]
    assert cycles == [], cycles
