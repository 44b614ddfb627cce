"""The layer rule of docs/design.md §12, executable.

Every module's imports are read with ``ast`` (so an import inside a function counts as
much as one at the top) and each must point to a lower layer or stay inside its own
package. A second check imports ``handvar.predictors`` in a fresh interpreter: the
predictors must not drag the hand model or its compiled geometry along.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "handvar"

# docs/design.md §12, from the bottom.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("validate",),
    ("atomic", "geometry"),
    ("camera", "params"),
    ("hand",),
    ("render", "io", "export"),
    ("synth", "vision", "predictors"),
    ("tracking",),
    ("evaluation",),
    ("cli",),
    ("__main__",),  # python -m handvar: the command line, nothing else
)
LAYER_OF = {part: level for level, parts in enumerate(LAYERS) for part in parts}


def _part(module: str) -> str | None:
    """``handvar.tracking.costs`` -> ``tracking``; None for the package root or a stranger."""
    names = module.split(".")
    if names[0] != "handvar" or len(names) < 2:
        return None
    return names[1]


def _module_name(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    names = list(rel.parts)
    if names[-1] == "__init__":
        names.pop()
    return ".".join(names)


def imported_modules(source: str, module: str, *, is_package: bool = False) -> list[str]:
    """Every handvar module that `source` (the text of `module`) imports, anywhere in it."""
    found = []
    package = module if is_package else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against the containing package
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            found.append(target)
            # ``from handvar import params`` imports the submodule handvar.params
            if target == "handvar":
                found += [f"handvar.{alias.name}" for alias in node.names]
    return [name for name in found if name == "handvar" or name.startswith("handvar.")]


def violations(source: str, module: str, *, is_package: bool = False) -> list[str]:
    """The imports of `module` that break the layer rule, as readable lines."""
    own = _part(module)
    if own is None:
        return []
    level = LAYER_OF.get(own)
    if level is None:
        return [f"{module}: not placed in any layer of docs/design.md §12"]
    bad = []
    for target in imported_modules(source, module, is_package=is_package):
        part = _part(target)
        if part is None or part == own:
            continue
        there = LAYER_OF.get(part)
        if there is None:
            bad.append(f"{module} imports {target}, which is in no layer")
        elif there >= level:
            way = "sideways" if there == level else "upwards"
            bad.append(f"{module} imports {target} ({way}: layer {level} -> {there})")
    return bad


def _modules():
    for path in sorted(SRC.rglob("*.py")):
        yield path, _module_name(path)


def test_every_module_imports_only_downwards():
    bad = []
    for path, module in _modules():
        bad += violations(path.read_text(), module, is_package=path.name == "__init__.py")
    assert not bad, "imports against the layer rule:\n" + "\n".join(bad)


def test_every_package_has_a_layer():
    parts = {_part(module) for _, module in _modules()} - {None}
    assert parts <= set(LAYER_OF), sorted(parts - set(LAYER_OF))


@pytest.mark.parametrize(
    ("module", "source", "expected"),
    [
        ("handvar.tracking.tracker", "from handvar.evaluation import metrics", "upwards"),
        ("handvar.tracking.init", "def f():\n    import handvar.cli\n", "upwards"),
        ("handvar.evaluation.report", "from handvar.cli.track import make_predictor", "upwards"),
        ("handvar.vision.sources", "from ..cli.common import _open_recordings", "upwards"),
        ("handvar.vision.skin", "from handvar.synth.motion import x", "sideways"),
        ("handvar.hand.surface", "from ..render import silhouettes", "upwards"),
        ("handvar.geometry.distortion", "from handvar import params", "upwards"),
        ("handvar.validate", "from handvar.atomic import write_atomic", "upwards"),
    ],
)
def test_the_rule_catches_an_upward_import(module, source, expected):
    # The checker itself must fail on the imports it exists to forbid.
    found = violations(source, module)
    assert len(found) == 1 and expected in found[0], found


@pytest.mark.parametrize(
    ("module", "source"),
    [
        ("handvar.tracking.tracker", "from handvar.tracking.costs import x"),
        ("handvar.tracking.tracker", "from .smd import minimise"),
        ("handvar.evaluation.report", "import handvar.tracking\nfrom handvar import params"),
        ("handvar.cli", "from handvar.evaluation import experiment"),
        ("handvar.cli.track", "from handvar.cli.synth import load_pose"),
        ("handvar.cli.init", "from .common import _recording_options"),
        ("handvar.cli", "from handvar.cli.track import make_predictor"),
    ],
)
def test_the_rule_allows_downward_and_internal_imports(module, source):
    assert violations(source, module) == []


def test_predictors_load_neither_the_hand_model_nor_compiled_geometry():
    code = (
        "import sys, handvar.predictors\n"
        "print(' '.join(sorted(m for m in sys.modules if m.startswith('handvar'))))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert "handvar.predictors" in out
    loaded = [
        m for m in out if m.startswith(("handvar.hand", "handvar.geometry", "handvar.render"))
    ]
    assert loaded == [], loaded
