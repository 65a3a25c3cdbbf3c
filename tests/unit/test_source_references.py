"""Docstrings and comments point inside the repository: to docs/ pages, never to notes a clone does not have.

A clone holds gcs/, sim_vehicles/, protocols/ and docs/; a docstring that sends the reader to
``reference/mavlink.md``, to ``../shared/`` or to a numbered section of a design note leads
nowhere. The design is docs/design.md, MAVLink docs/mavlink.md, Zenoh docs/protocol.md#zenoh.
"""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("gcs", "sim_vehicles", "protocols")
OUTSIDE = re.compile(r"(?<![\w/])reference/|\.\./shared|design\.md,?\s+(?:section|§)", re.IGNORECASE)
"""A path into the reference notes, the shared folder beside the repository, or a section of a design note."""


def outside_references(source: str) -> list[str]:
    """The comments and string literals (docstrings among them) of Python ``source`` that point outside the
    repository, as ``line: text``."""
    found = []
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type in (tokenize.COMMENT, tokenize.STRING) and OUTSIDE.search(token.string):
            found.append(f"{token.start[0]}: {token.string.strip()[:100]}")
    return found


def test_the_check_finds_each_kind_of_outside_reference() -> None:
    source = '''"""Facts from reference/mavlink.md."""
x = 1  # see ../shared/design.md
def f():
    """As design.md section 8 says."""
y = "docs/mavlink.md"  # inside: not reported
'''
    assert [line.split(":")[0] for line in outside_references(source)] == ["1", "2", "4"]


def test_no_docstring_or_comment_points_outside_the_repository() -> None:
    found = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            found += [f"{path.relative_to(ROOT)}:{hit}" for hit in outside_references(path.read_text(encoding="utf-8"))]
    assert found == []
