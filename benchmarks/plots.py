"""What every ``gcs-bench ... --plots DIR`` writes: PNG figures and one markdown table file.

Figures are drawn with matplotlib's non-interactive Agg backend (no display
needed) and saved at 120 dpi; the markdown file holds the benchmark's tables
with the numbers of its JSON report, formatted by :func:`cell` (four
significant digits), so that a table row can be checked against the JSON.
matplotlib is imported only when a figure is made: the benchmarks themselves
(and ``gcs/core``) never need it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

__all__ = ["pyplot", "save", "cell", "markdown_table", "write_markdown", "DPI", "PNG_MAGIC"]

DPI = 120
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (files only, no window)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, directory: Path, name: str, written: list[Path] | None = None) -> Path:
    """Save ``fig`` as ``directory / name`` (PNG), close it, and append the path to ``written``."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / name
    fig.savefig(path, dpi=DPI, bbox_inches="tight")
    pyplot().close(fig)
    if written is not None:
        written.append(path)
    return path


def cell(value: object, digits: int = 4) -> str:
    """One table cell: ``-`` for None/NaN, ``yes``/``no``, integers as they are, floats to ``digits``
    significant digits (no exponent below 1e6), anything else as text with ``|`` escaped."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        if value != 0 and (abs(value) >= 1e6 or abs(value) < 1e-3):
            return f"{value:.{digits - 1}e}"
        places = max(digits - 1 - math.floor(math.log10(abs(value))), 0) if value else digits - 1
        return f"{value:.{places}f}"
    return str(value).replace("|", "\\|")


def markdown_table(columns: Sequence[str], rows: Sequence[Sequence[object]], digits: int = 4) -> str:
    """A GitHub-flavoured markdown table; numbers right-aligned."""
    numeric = [all((isinstance(row[i], (int, float)) and not isinstance(row[i], bool)) or row[i] is None for row in rows)
               for i in range(len(columns))]
    lines = ["| " + " | ".join(columns) + " |",
             "|" + "|".join("---:" if n else "---" for n in numeric) + "|"]
    lines += ["| " + " | ".join(cell(v, digits) for v in row) + " |" for row in rows]
    return "\n".join(lines)


def write_markdown(directory: Path, name: str, title: str,
                   sections: Sequence[tuple[str, Sequence[str], Sequence[Sequence[object]]]],
                   notes: Sequence[str] = (), written: list[Path] | None = None) -> Path:
    """``directory / name``: a title, then per section a heading and its table, then notes."""
    directory.mkdir(parents=True, exist_ok=True)
    parts = [f"# {title}", ""]
    for heading, columns, rows in sections:
        parts += [f"## {heading}", "", markdown_table(columns, rows), ""]
    parts += [f"- {note}" for note in notes]
    path = directory / name
    path.write_text("\n".join(parts).rstrip("\n") + "\n")
    if written is not None:
        written.append(path)
    return path
