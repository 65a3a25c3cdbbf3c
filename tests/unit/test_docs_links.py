"""Links in the docs lead to files and headings that exist, inside the repository.

README.md and docs/*.md link to each other, to sections by anchor
(`[benchmarks](docs/benchmarks.md#soak-gcs-bench-soak)`), and the pages link to
their own sections (`(#replay-gcs-bench-replay)`). A renamed heading breaks such a link
silently on GitHub; here every one is resolved against the target's headings, with
GitHub's anchor rules: lowercase, punctuation dropped (letters, digits, spaces, hyphens
and underscores kept), each space a hyphen, and a repeated heading suffixed -1, -2, ...
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SOURCES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
README_MAX_LINES = 300
"""A newcomer reads the README through; the reference lives in docs/."""

_LINK = re.compile(r"\]\(([^)\s]*)\)")
_HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")


def github_slug(heading: str) -> str:
    """The anchor GitHub gives a heading's text (before the -1, -2 of repeats)."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(markdown: str) -> set[str]:
    """Every heading's anchor in a markdown text; headings inside fenced code do not count."""
    found: set[str] = set()
    seen: dict[str, int] = {}
    fenced = False
    for line in markdown.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        match = None if fenced else _HEADING.match(line)
        if match is None:
            continue
        slug = github_slug(match.group(1))
        repeat = seen.get(slug, 0)
        seen[slug] = repeat + 1
        found.add(slug if repeat == 0 else f"{slug}-{repeat}")
    return found


def links(source: Path) -> list[str]:
    """Every link target written in a markdown file."""
    return _LINK.findall(source.read_text(encoding="utf-8"))


def section_links(source: Path) -> list[tuple[Path, str]]:
    """(target file, anchor) of each link to a section of a markdown page, or of the source itself."""
    found = []
    for target in links(source):
        path, sep, anchor = target.partition("#")
        if not sep or not anchor or "://" in path:
            continue
        if path == "":
            found.append((source, anchor))
        elif path.endswith(".md"):
            found.append(((source.parent / path).resolve(), anchor))
    return found


@pytest.mark.parametrize(
    ("heading", "slug"),
    [
        ("Soak: `gcs-bench soak`", "soak-gcs-bench-soak"),
        ("Planning in the city: `gcs-bench urban`", "planning-in-the-city-gcs-bench-urban"),
        ("`wang2012_urban`: the paper's experiment", "wang2012_urban-the-papers-experiment"),
        ("In the tracking loop: `gcs-bench urban --gps-denied`", "in-the-tracking-loop-gcs-bench-urban---gps-denied"),
        ("A manoeuvring target (IMM): `gcs-bench imm`", "a-manoeuvring-target-imm-gcs-bench-imm"),
        ("In the daemon: `--navigation skf|reported`", "in-the-daemon---navigation-skfreported"),
    ],
)
def test_github_slug(heading: str, slug: str) -> None:
    assert github_slug(heading) == slug


def test_repeated_headings_and_code_blocks() -> None:
    text = "# Page\n## Against the goals\n```sh\n# a comment\n```\n### Against the goals\n"
    assert anchors(text) == {"page", "against-the-goals", "against-the-goals-1"}


def test_the_docs_link_to_sections_that_exist() -> None:
    links = [(source, target, anchor) for source in SOURCES for target, anchor in section_links(source)]
    assert any(target.name == "benchmarks.md" for _, target, _ in links)  # the README's status table at least
    broken = [
        f"{source.relative_to(ROOT)} -> {target.relative_to(ROOT)}#{anchor}"
        for source, target, anchor in links
        if not target.is_file() or anchor not in anchors(target.read_text(encoding="utf-8"))
    ]
    assert broken == []


def test_every_link_stays_inside_the_repository_and_finds_its_file() -> None:
    outside, missing = [], []
    for source in SOURCES:
        for target in links(source):
            path = target.partition("#")[0]
            if "://" in target or target.startswith("mailto:"):
                outside.append(f"{source.relative_to(ROOT)} -> {target}")
            elif path:
                resolved = (source.parent / path).resolve()
                if ROOT not in resolved.parents:
                    outside.append(f"{source.relative_to(ROOT)} -> {target}")
                elif not resolved.exists():
                    missing.append(f"{source.relative_to(ROOT)} -> {target}")
    assert outside == [] and missing == []


def test_the_readme_is_short_and_names_nothing_outside_the_repository() -> None:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= README_MAX_LINES
    for source in SOURCES:
        assert "../shared" not in source.read_text(encoding="utf-8"), source.name
