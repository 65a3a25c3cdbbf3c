"""gcs/core and gcs/engine stay pure: no I/O modules, no clock, no thread, no global random state.

The rule (docs/design.md, the layers): ``gcs.core`` imports only numpy, scipy,
filterpy, the standard library's pure modules and ``protocols``; the engine
(``gcs.engine``) the same, plus ``gcs.core``, ``gcs.config`` and ``logging``.
Neither opens a socket, reads a clock, starts a thread or uses the global numpy
RNG: time and a ``numpy.random.Generator`` are arguments. Checked on the source
(every import, anywhere in a module) and on a fresh interpreter: importing the
engine loads nothing of the adapters, the shells or their I/O libraries.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CORE = ROOT / "gcs" / "core"
ENGINE = ROOT / "gcs" / "engine"
CORE_PACKAGES = ("gcs.core",)
"""What ``gcs.core`` may import of ``gcs``."""
ENGINE_PACKAGES = ("gcs.core", "gcs.config", "gcs.engine")
"""What ``gcs.engine`` may import of ``gcs``."""
ENGINE_STDLIB = {"logging"}
"""What the engine may import of the standard library beyond the core's: it logs what it decides."""
SHELL_LIBRARIES = ("zenoh", "pymavlink", "mcap", "foxglove", "matplotlib", "dask")

ALLOWED_THIRD_PARTY = {"numpy", "scipy", "filterpy", "protocols", "numba"}
"""numba compiles the core's kernels in memory; caching them to disk would be I/O (checked below)."""
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
SEEDED_CONSTRUCTOR = "default_rng"
"""Allowed when called with a seed (``default_rng([seed, stamp])``): its draws are a function of the seed."""


def _dotted(node: ast.AST) -> str | None:
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name):
        parts.append(node.id)
        return ".".join(reversed(parts))
    return None


def violations(source: str, filename: str = "<source>", packages: tuple[str, ...] = CORE_PACKAGES,
               stdlib: frozenset[str] | set[str] = frozenset()) -> list[str]:
    """Every breach of the import and randomness rules in one module's source: ``packages`` are what it may
    import of ``gcs``, ``stdlib`` the standard library modules it may import beyond the core's."""
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
                if not any(name == package or name.startswith(package + ".") for package in packages):
                    found.append(f"{filename}:{node.lineno}: imports {name} (only {', '.join(packages)} may be)")
            elif top in stdlib:
                continue
            elif top in FORBIDDEN_STDLIB or (top not in ALLOWED_THIRD_PARTY and top not in ALLOWED_STDLIB):
                found.append(f"{filename}:{node.lineno}: imports {name}")
    # a generator seeded where it is made is the caller's, not a global one: default_rng(seed) is allowed
    seeded = {id(node.func) for node in ast.walk(tree) if isinstance(node, ast.Call)
              and isinstance(node.func, ast.Attribute) and node.func.attr == SEEDED_CONSTRUCTOR
              and (node.args or node.keywords)
              and not any(isinstance(a, ast.Constant) and a.value is None
                          for a in [*node.args, *(k.value for k in node.keywords)])}
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            dotted = _dotted(node)
            if dotted is None or id(node) in seeded:
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
        problems += violations(path.read_text(), str(path.relative_to(ROOT)))
    assert problems == []


def disk_caching_jits(source: str, filename: str = "<source>") -> list[str]:
    """Every numba ``jit``/``njit`` call in ``source`` that does not say ``cache=False`` (numba's cache is files)."""
    found = []
    for node in ast.walk(ast.parse(source, filename)):
        if isinstance(node, ast.Call) and (_dotted(node.func) or "").split(".")[-1] in ("jit", "njit"):
            cache = [k.value for k in node.keywords if k.arg == "cache"]
            if not (cache and isinstance(cache[0], ast.Constant) and cache[0].value is False):
                found.append(f"{filename}:{node.lineno}: {_dotted(node.func)} without cache=False")
    return found


def test_the_core_compiles_nothing_to_disk() -> None:
    problems = []
    for path in sorted(CORE.rglob("*.py")):
        problems += disk_caching_jits(path.read_text(), str(path.relative_to(ROOT)))
    assert problems == []
    assert disk_caching_jits("import numba\nf = numba.njit(cache=True)(len)") != []
    assert disk_caching_jits("from numba import njit\nf = njit(len)") != []
    assert disk_caching_jits("import numba\nf = numba.njit(cache=False)(len)") == []


def test_every_engine_module_is_pure() -> None:
    problems = []
    for path in sorted(ENGINE.rglob("*.py")):
        problems += violations(path.read_text(), str(path.relative_to(ROOT)), ENGINE_PACKAGES, ENGINE_STDLIB)
    assert (ENGINE / "engine.py").is_file()
    assert problems == []


@pytest.mark.parametrize("source", ["from gcs.daemon.app import Daemon", "from gcs.adapters.zenoh_io import ZenohIO",
                                    "from gcs.scenarios import load_scenario", "import threading", "import time",
                                    "import socket"])
def test_the_engine_checker_catches_an_import_of_a_shell_a_clock_or_a_thread(source: str) -> None:
    assert violations(source, packages=ENGINE_PACKAGES, stdlib=ENGINE_STDLIB) != []


def test_the_engine_checker_accepts_what_the_engine_uses() -> None:
    source = ("import logging\nfrom gcs.config import Scenario\nfrom gcs.core.tracker import fuse\n"
              "from gcs.engine.events import Tick\nfrom protocols.messages import SensorReport")
    assert violations(source, packages=ENGINE_PACKAGES, stdlib=ENGINE_STDLIB) == []
    assert violations(source) != []  # the core may import neither logging, gcs.config nor gcs.engine


def modules_loaded_by(*modules: str) -> list[str]:
    """Every module a fresh interpreter holds after importing ``modules`` (and, for a package, its modules)."""
    code = ("import importlib, pkgutil, sys\n"
            "for name in sys.argv[1:]:\n"
            "    module = importlib.import_module(name)\n"
            "    for info in pkgutil.walk_packages(getattr(module, '__path__', []), name + '.'):\n"
            "        importlib.import_module(info.name)\n"
            "print(' '.join(sorted(sys.modules)))\n")
    result = subprocess.run([sys.executable, "-c", code, *modules], capture_output=True, text=True, check=True,
                            cwd=ROOT, timeout=300)
    return result.stdout.split()


def shell_modules(loaded: list[str]) -> list[str]:
    """The modules of ``loaded`` the engine must not load: ``gcs`` beyond the core, the scenario model and the
    engine, and the I/O libraries of the adapters and the shells."""
    return [name for name in loaded
            if (name.startswith("gcs.") and not name.startswith(tuple(p + "." for p in ENGINE_PACKAGES))
                and name not in ENGINE_PACKAGES)
            or name.split(".")[0] in SHELL_LIBRARIES or name.split(".")[0] == "sim_vehicles"]


def test_importing_the_engine_loads_no_adapter_shell_or_io_library() -> None:
    loaded = modules_loaded_by("gcs.engine")
    assert "gcs.engine.engine" in loaded and "gcs.core.tracker" in loaded
    assert shell_modules(loaded) == []


def test_importing_the_daemon_loads_the_adapters_and_zenoh() -> None:
    """The check above sees what it looks for: the daemon's composition root loads both."""
    found = shell_modules(modules_loaded_by("gcs.daemon.app"))
    assert "gcs.adapters.zenoh_io" in found and "zenoh" in found and "gcs.daemon.app" in found


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
        "import numpy as np\nrng = np.random.default_rng\nrng(3)",
        "import numpy as np\nrng = np.random.default_rng(None)",
        "import numpy as np\nrng = np.random.default_rng(seed=None)",
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
        "import numpy as np\ndef draws(seed: int, stamp: int):\n    return np.random.default_rng([seed, stamp])",
    ],
)
def test_checker_accepts_pure_code(source: str) -> None:
    assert violations(source) == []
