"""The import graph of simgen/, train/ and scan_patterns/ has no cycle at module level, and validating a scenario
imports no dataset format's module (its limits are the registry's): the circle scenario -> format plug-in ->
manifest -> scan.sensor -> scenario is gone."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from tests.support import ROOT

PACKAGES = ("simgen", "train", "scan_patterns")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imported(body: list[ast.stmt], module: str, package: bool) -> set[str]:
    """Dotted names that statements `body` of `module` import when the module is imported: its top level, its
    top-level `if`/`try` blocks, not `if TYPE_CHECKING:` blocks nor function bodies."""
    names: set[str] = set()
    for node in body:
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = module.split(".")[: len(module.split(".")) - node.level + package]
                base = ".".join([*parent, base] if base else parent)
            names |= {base} | {f"{base}.{alias.name}" for alias in node.names}
        elif isinstance(node, ast.If):
            if "TYPE_CHECKING" not in ast.unparse(node.test):
                names |= _imported(node.body, module, package)
            names |= _imported(node.orelse, module, package)
        elif isinstance(node, ast.Try):
            for block in (node.body, node.orelse, node.finalbody, *(handler.body for handler in node.handlers)):
                names |= _imported(block, module, package)
    return names


def import_graph() -> dict[str, set[str]]:
    """Module -> the modules of PACKAGES it imports at module level (a dotted import counts every package on
    its way, `a.b.c` imports `a` and `a.b`; a module's own packages are left out: they are loaded before it)."""
    paths = {_module_name(path): path for package in PACKAGES for path in (ROOT / package).rglob("*.py")}
    graph = {}
    for module, path in paths.items():
        edges = set()
        for name in _imported(ast.parse(path.read_text()).body, module, path.name == "__init__.py"):
            parts = name.split(".")
            prefixes = (".".join(parts[:end]) for end in range(1, len(parts) + 1))
            edges |= {p for p in prefixes if p in paths and p != module and not module.startswith(p + ".")}
        graph[module] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_cycles_finds_a_circle_and_nothing_in_a_line():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_no_module_level_import_cycle():
    graph = import_graph()
    assert len(graph) > 150 and {"simgen.scan.sensor", "simgen.datasets.formats"} <= graph["simgen.datasets.manifest"]
    assert cycles(graph) == []


def test_validating_a_scenario_imports_no_format_module(tmp_path):
    """A KITTI scenario with placeholder images and one whose clips are too long for KITTI's numbering: both
    are judged by the registry's limits, no format's module imported."""
    probe = (
        "import sys, yaml\n"
        "from simgen.errors import UserError\n"
        "from simgen.scenario import load_scenario\n"
        "scenario = yaml.safe_load(open('scenarios/smoke.yaml'))\n"
        "scenario['dataset'] = {'format': 'kitti', 'kitti_images': True}\n"
        f"yaml.safe_dump(scenario, open({str(tmp_path / 'kitti.yaml')!r}, 'w'))\n"
        "load_scenario(sys.argv[1])\n"
        "scenario['dataset'] = {'format': 'mcap', 'kitti_images': True}\n"
        f"yaml.safe_dump(scenario, open({str(tmp_path / 'mcap.yaml')!r}, 'w'))\n"
        "try:\n"
        "    load_scenario(sys.argv[2])\n"
        "except UserError as error:\n"
        "    print(error)\n"
        "print(sorted(m for m in sys.modules if m.startswith('simgen.datasets.formats.')))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", probe, str(tmp_path / "kitti.yaml"), str(tmp_path / "mcap.yaml")],
        capture_output=True, text=True, cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": ""},
    )
    lines = result.stdout.splitlines()
    assert result.returncode == 0 and len(lines) == 2, result.stderr[-2000:]
    assert "placeholder images are for format kitti, not mcap" in lines[0]
    assert lines[1] == "[]"
