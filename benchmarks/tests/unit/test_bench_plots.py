"""The benchmarks' shared output: table cells, markdown tables, PNG figures, and the --plots/--json checks."""

from __future__ import annotations

import math

import pytest

from benchmarks.plots import PNG_MAGIC, cell, markdown_table, pyplot, save, write_markdown
from benchmarks.cli import main
from benchmarks.tests.markdown_tables import read_tables


@pytest.mark.parametrize("value, text", [
    (None, "-"), (math.nan, "-"), (True, "yes"), (False, "no"), (12, "12"), (-3, "-3"),
    (1234.5678, "1235"), (12.345678, "12.35"), (0.123456, "0.1235"), (0.0, "0.000"), (-2.5, "-2.500"),
    (1.5e7, "1.500e+07"), (2.5e-5, "2.500e-05"), (math.inf, "inf"), ("a|b", "a\\|b"),
])
def test_cells_keep_four_significant_digits(value, text) -> None:
    assert cell(value) == text


@pytest.mark.parametrize("value", [1e-3, 0.0123456, 3.14159, 99.999, 12345.6, 987654.3])
def test_a_cell_reads_back_within_the_digits_it_keeps(value) -> None:
    assert math.isclose(float(cell(value)), value, rel_tol=5e-4)


def test_markdown_tables_align_numbers_and_read_back(tmp_path) -> None:
    assert markdown_table(["name", "x"], [("a", 1.0), ("b", None)]).splitlines()[1] == "|---|---:|"
    path = write_markdown(tmp_path / "out", "t.md", "Title", [
        ("First", ["name", "value", "ok"], [("a", 1.5, True), ("b", 2, False)]),
        ("Second", ["n"], [(7,)]),
    ], ["a note"])
    text = path.read_text()
    assert text.startswith("# Title\n") and text.endswith("- a note\n")
    assert read_tables(path) == {"First": [{"name": "a", "value": "1.500", "ok": "yes"},
                                           {"name": "b", "value": "2", "ok": "no"}],
                                 "Second": [{"n": "7"}]}


def test_figures_are_saved_as_png(tmp_path) -> None:
    fig, ax = pyplot().subplots()
    ax.plot([0, 1], [1, 0])
    written: list = []
    path = save(fig, tmp_path / "deep" / "er", "line.png", written)
    assert written == [path] and path.read_bytes()[:8] == PNG_MAGIC


def test_bench_refuses_a_json_path_in_a_missing_folder_before_running(tmp_path, capsys) -> None:
    missing = tmp_path / "nowhere" / "out.json"
    assert main(["replay", "--duration", "1", "--json", str(missing)]) == 2
    assert "no folder" in capsys.readouterr().err and not missing.parent.exists()


def test_bench_refuses_a_plots_folder_it_cannot_make(tmp_path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["replay", "--duration", "1", "--plots", str(blocker / "plots")]) == 2
    assert "--plots" in capsys.readouterr().err
