"""The package's layers, read from the imports of its source files.

input and numerics -> segmentation -> {depthmap, relief} -> view -> formats ->
chain -> front ends (cli, editor, batch). A module imports only from its own
layer or below; the 2014 relief never imports the 2010 depth map (nor the
reverse); numerics knows no inkray concept; nothing imports names from the
package's ``__init__``.
"""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "inkray"

# (prefix, layer): the longest matching prefix wins.
LAYERS = [
    ("inkray._version", 0), ("inkray.errors", 0), ("inkray.progress", 0),
    ("inkray.numerics", 1), ("inkray.input", 1), ("inkray.examples", 1),
    ("inkray.segmentation", 2),
    ("inkray.depthmap", 3), ("inkray.relief", 3), ("inkray.transfer", 3),
    ("inkray.view", 4),
    ("inkray.formats", 5),
    ("inkray.chain", 6), ("inkray.validation", 6), ("inkray.composition", 6), ("inkray.artefacts", 6),
    ("inkray.cli", 7), ("inkray.__main__", 7), ("inkray.editor", 7), ("inkray.batch", 7),
]
APART = [("inkray.relief", "inkray.depthmap"), ("inkray.depthmap", "inkray.relief")]


def _layer(module):
    best = max((p for p in LAYERS if module == p[0] or module.startswith(p[0] + ".")),
               key=lambda p: len(p[0]), default=None)
    return None if best is None else best[1]


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts.pop()
        yield ".".join(parts), path


def _imports(module, path):
    """Absolute names of the inkray modules (or names) ``path`` imports."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno, None
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")
                up = up[:len(up) - node.level + 1]
                base = ".".join(up + ([base] if base else []))
            yield base, node.lineno, [a.name for a in node.names]


MODULES = [m for m in _modules() if m[0] != "inkray"]


def test_every_module_has_a_layer():
    missing = [m for m, _ in MODULES if _layer(m) is None]
    assert not missing, f"give these modules a layer in LAYERS: {missing}"


@pytest.mark.parametrize("module, path", MODULES, ids=[m for m, _ in MODULES])
def test_imports_go_down_only(module, path):
    mine = _layer(module)
    bad = []
    for target, line, names in _imports(module, path):
        if target != "inkray" and not target.startswith("inkray."):
            continue
        if target == "inkray":
            if names is not None and any(n != "__version__" for n in names):
                bad.append(f"line {line}: imports {names} from the package __init__")
            continue
        layer = _layer(target)
        if layer is not None and layer > mine:
            bad.append(f"line {line}: {target} is above {module}")
        for a, b in APART:
            if module.startswith(a) and target.startswith(b):
                bad.append(f"line {line}: {module} must not import {target}")
        if module.startswith("inkray.numerics") and not target.startswith(
                ("inkray.numerics", "inkray.errors")):
            bad.append(f"line {line}: numerics imports the inkray concept {target}")
    assert not bad, "\n".join(bad)


def test_no_function_hides_its_module():
    import importlib
    import pkgutil

    import inkray

    for info in pkgutil.walk_packages(inkray.__path__, "inkray."):
        parent, _, name = info.name.rpartition(".")
        module = importlib.import_module(info.name)
        assert getattr(importlib.import_module(parent), name) is module, \
            f"{parent}.{name} is not the module {info.name}"
