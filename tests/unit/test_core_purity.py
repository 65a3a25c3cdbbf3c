"""gcs/core stays pure: no I/O modules, no clock, no global random state.

The rule (design.md section 2): ``gcs.core`` imports only numpy, scipy,
filterpy, the standard library and ``protocols``; it never opens a socket,
reads a clock or uses the global numpy RNG. Time and a
``numpy.random.Generator`` are arguments.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

CORE = Path(__file__).resolve().parents[2] / "gcs" / "core"

ALLOWED_THIRD_PARTY = {"numpy", "scipy", "filterpy", "protocols"}
FORBIDDEN_STDLIB = {
    "time", "socket", "random", "os", "sys", "io", "pathlib", "shutil", "subprocess", "threading",
    "multiprocessing", "asyncio", "datetime", "select", "selectors", "signal", "logging", "urllib",
    "http", "ssl", "tempfile", "glob", "sqlite3", "pickle", "secrets", "uuid",
}
ALLOWED_STDLIB = {
    "__future__", "math", "cmath", "dataclasses", "typing", "collections", "functools", "itertools",
    "enum", "abc", "numbers", "operator", "heapq", "bisect", "statistics", "types", "warnings",
}
# numpy.random attributes that are types, not draws from the global generator.
ALLOWED_NUMPY_RANDOM = {"Generator", "BitGenerator", "SeedSequence"}


def _dotted(node: ast.AST) -> str | None:
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
        return ".".join(reversed(parts))
    return None


def violations(source: str, filename: str = "<source>") -> list[str]:
    """Every breach of the core's import and randomness rules in one module's source."""
    tree = ast.parse(source, filename)
    found: list[str] = []
    numpy_aliases = {"numpy"}
    random_aliases: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules = [(a.name, a.asname) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative import inside gcs.core
                continue
            modules = [(node.module or "", None)]
            if node.module in ("numpy.random",):
                bad = [a.name for a in node.names if a.name not in ALLOWED_NUMPY_RANDOM]
                if bad:
                    found.append(f"{filename}:{node.lineno}: imports {bad} from numpy.random (global RNG)")
        else:
            modules = []
        for name, alias in modules:
            top = name.split(".")[0]
            if name == "numpy" and alias:
                numpy_aliases.add(alias)
            if name == "numpy.random":
                random_aliases.add(alias or "numpy.random")
            if top == "gcs":
                if not (name == "gcs.core" or name.startswith("gcs.core.")):
                    found.append(f"{filename}:{node.lineno}: imports {name} (only gcs.core may be imported)")
            elif top in FORBIDDEN_STDLIB or (top not in ALLOWED_THIRD_PARTY and top not in ALLOWED_STDLIB):
                found.append(f"{filename}:{node.lineno}: imports {name}")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            dotted = _dotted(node)
            if dotted is None:
                continue
            head, _, rest = dotted.partition(".")
            if head in numpy_aliases and rest.startswith("random."):
                attr = rest.split(".")[1]
                if attr not in ALLOWED_NUMPY_RANDOM:
                    found.append(f"{filename}:{node.lineno}: uses {dotted} (global or unseeded RNG)")
            elif dotted.split(".")[0] in random_aliases:
                attr = dotted.split(".")[-1]
                if attr not in ALLOWED_NUMPY_RANDOM:
                    found.append(f"{filename}:{node.lineno}: uses {dotted} (global or unseeded RNG)")
    return sorted(set(found))


def test_core_modules_exist() -> None:
    assert (CORE / "geometry.py").is_file()


def test_every_core_module_is_pure() -> None:
    problems = []
    for path in sorted(CORE.rglob("*.py")):
        problems += violations(path.read_text(), str(path.relative_to(CORE.parent.parent)))
    assert problems == []


@pytest.mark.parametrize(
    "source",
    [
        "import zenoh",
        "from pymavlink import mavutil",
        "import socket",
        "import time",
        "from time import monotonic",
        "import random",
        "import os",
        "from gcs.adapters import zenoh_io",
        "import numpy as np\nx = np.random.normal(size=3)",
        "import numpy\nnumpy.random.seed(1)",
        "import numpy as np\nrng = np.random.default_rng()",
        "from numpy.random import rand",
        "import numpy.random as npr\nnpr.uniform()",
    ],
)
def test_checker_catches_each_kind_of_breach(source: str) -> None:
    assert violations(source) != []


@pytest.mark.parametrize(
    "source",
    [
        "import numpy as np\ndef f(rng: np.random.Generator) -> float:\n    return rng.normal()",
        "import math\nfrom dataclasses import dataclass",
        "from scipy.linalg import cho_factor",
        "from protocols import SensorReport",
        "from gcs.core.geometry import wrap_angle",
        "from .geometry import wrap_angle",
    ],
)
def test_checker_accepts_pure_code(source: str) -> None:
    assert violations(source) == []
