"""Reading back the markdown tables ``gcs-bench --plots`` writes, to check them against the JSON report."""

from __future__ import annotations

import math
from pathlib import Path

from benchmarks.plots import PNG_MAGIC

__all__ = ["read_tables", "number", "assert_close", "assert_pngs"]


def read_tables(path: Path) -> dict[str, list[dict[str, str]]]:
    """Every table of the file under its ``## heading``: a list of rows, each {column: cell text}."""
    tables: dict[str, list[dict[str, str]]] = {}
    heading, columns = None, None
    for line in path.read_text().splitlines():
        if line.startswith("## "):
            heading, columns = line[3:], None
            tables[heading] = []
        elif line.startswith("|") and heading is not None:
            cells = [c.strip() for c in line.strip("|").split(" | ")]
            if columns is None:
                columns = cells
            elif not set(line) <= set("|-: "):
                assert len(cells) == len(columns), f"{path}: {line!r} has {len(cells)} cells for {len(columns)} columns"
                tables[heading].append(dict(zip(columns, cells)))
    return tables


def number(text: str) -> float:
    """A numeric cell; ``-`` is NaN."""
    return math.nan if text == "-" else float(text)


def assert_close(cell: str, value: float | None) -> None:
    """A cell shows ``value`` to the four significant digits the tables keep."""
    if value is None:
        assert cell == "-", cell
    else:
        assert math.isclose(number(cell), value, rel_tol=1e-3, abs_tol=1e-9), (cell, value)


def assert_pngs(folder: Path, names: list[str]) -> None:
    """Each file is a non-empty PNG."""
    for name in names:
        data = (folder / name).read_bytes()
        assert data[:8] == PNG_MAGIC and len(data) > 5000, name
