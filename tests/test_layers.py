"""The package's layers import downward only (docs/architecture.md): every import of every module under ``wqwarp/``
and ``kernels/`` (module level and inside functions, ``import x`` and ``from x import y``, relative imports
resolved; read with ``ast``, nothing is imported) names a module of its own layer or of a layer below it.

Imports by string (``importlib.import_module`` on the registries ``BACKEND_CLASSES`` and
``TrainConfig.algorithm_class``) are not seen here; both registries name modules of their own layer.
"""

from __future__ import annotations

import ast
import os
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# Each comment names the imports that place a layer above the ones before it ("by choice": no import decides).
LAYERS: tuple[tuple[str, ...], ...] = (
    ("wqwarp",),  # the package's __init__ (__version__, quiet_warp), imported by kernels; imports nothing of ours
    ("utils",),  # atomic writes, checked configs, provenance; below robot by choice (no import between them)
    ("robot",),  # joint order, geometry, the USD into Newton
    ("kernels",),  # the Warp math (kernels/, installed as wqwarp.kernels): kernels.gait reads robot's constants
    ("sim",),  # Simulator and its backends (featherstone's penalty physics too): kernels, robot, utils
    ("control",),  # gait library, nominal gait, open-loop driver: control.driver drives sim's Simulator
    ("diff", "rl"),  # peers, neither imports the other: both import control (gaits) and sim
    ("eval",),  # protocols: rl's env, presets and checkpoints
    ("viz",),  # USD and video of rollouts (robot, utils); above eval by choice, as an output stage
    ("cli",),  # the command lines and the tools' main()s: eval, viz, diff, rl and the rest
)
"""Lowest first. A module may import its own layer and any layer of a lower rank; layers of one rank (peers) may
not import each other."""

RANK = {layer: rank for rank, peers in enumerate(LAYERS) for layer in peers}

PENDING: set[tuple[str, str]] = set()
"""(importing module, imported module): upward edges allowed for now (none: the evaluation's and the reproduction's
command lines moved to wqwarp/cli/). An entry must name an edge that exists (test_pending_edges_still_exist)."""


def _module_files() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the package (``kernels/`` as ``wqwarp.kernels``)."""
    out = {}
    for top, prefix in (("wqwarp", ("wqwarp",)), ("kernels", ("wqwarp", "kernels"))):
        for path in sorted((ROOT / top).rglob("*.py")):
            parts = (*prefix, *path.relative_to(ROOT / top).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


MODULES = _module_files()


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


def _imports(module: str, path: Path) -> list[tuple[int, str]]:
    """(line, imported module) of every import in ``path`` that names the package (``kernels`` counts as
    ``wqwarp.kernels``); ``from a import b`` is ``a.b`` when that is a module of the package, else ``a``."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            if source == "kernels" or source.startswith("kernels."):
                source = "wqwarp." + source
            names = [f"{source}.{a.name}" if f"{source}.{a.name}" in MODULES else source for a in node.names]
        else:
            continue
        for name in names:
            if name == "kernels" or name.startswith("kernels."):
                name = "wqwarp." + name
            if name == "wqwarp" or name.startswith("wqwarp."):
                found.append((node.lineno, name))
    return found


def _edges():
    """(module, file, line, imported module) of every import of the package by the package."""
    for module, path in MODULES.items():
        for line, target in _imports(module, path):
            yield module, path, line, target


def test_every_folder_of_the_package_is_a_layer_and_the_order_is_the_documented_one():
    folders = {p.name for p in (ROOT / "wqwarp").iterdir() if (p / "__init__.py").exists()} | {"kernels", "wqwarp"}
    assert folders == set(RANK), f"layers without a folder or folders without a layer: {folders ^ set(RANK)}"
    assert {_layer(m) for m in MODULES} == set(RANK)
    order = " < ".join(" = ".join(f"`{layer}`" for layer in peers) for peers in LAYERS)
    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    assert order in doc, f"docs/architecture.md should state the layer order the test enforces: {order}"


def test_no_module_imports_a_layer_above_its_own():
    bad = []
    for module, path, line, target in _edges():
        own, other = _layer(module), _layer(target)
        assert other in RANK, f"{path.relative_to(ROOT)}:{line}: {module} imports {target}, of no known layer"
        if own == other or RANK[other] < RANK[own] or (module, target) in PENDING:
            continue
        where = "a peer layer" if RANK[other] == RANK[own] else "a layer above"
        bad.append(
            f"{path.relative_to(ROOT)}:{line}: {module} (layer {own}) imports {target}: layer {other}, {where} its own"
        )
    assert not bad, "upward imports:" + "".join(f"{os.linesep}  {b}" for b in bad)


def test_pending_edges_still_exist():
    edges = {(module, target) for module, _, _, target in _edges()}
    gone = sorted(PENDING - edges)
    assert not gone, f"PENDING names edges that no longer exist, delete them from tests/test_layers.py: {gone}"
    for module, target in PENDING:  # an allowed edge is still an upward one, or it would not need allowing
        assert RANK[_layer(target)] >= RANK[_layer(module)] and _layer(target) != _layer(module)
