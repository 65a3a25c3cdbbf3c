"""``gcs scenario from-osm``'s bad input: one line naming it, exit status 2, nothing written."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from gcs.cli import main
from tests.unit.osm.extract import DATA_M, box_degrees, write_pbf, write_xml

PROG = "gcs scenario from-osm: error: "


def _box(box_m: tuple[float, float, float, float]) -> str:
    return ",".join(repr(v) for v in box_degrees(box_m))


GOOD = _box((-50.0, -50.0, 250.0, 250.0))


@pytest.fixture(scope="module")
def extract(tmp_path_factory) -> Path:
    return write_xml(tmp_path_factory.mktemp("extract") / "town.osm")


def _refused(argv: list[str], capsys) -> list[str]:
    try:
        code = main(["scenario", "from-osm", *argv])
    except SystemExit as stop:  # argparse's own errors
        code = stop.code
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1, (code, lines)
    assert "Traceback" not in lines[0]
    return lines


@pytest.mark.parametrize(("bbox", "message"), [
    ("24.9,60.1,25.0", "--bbox 24.9,60.1,25.0: give four numbers W,S,E,N"),
    ("a,b,c,d", "--bbox a,b,c,d: give four numbers"),
    ("24.9,60.1,25.0,nan", "give four numbers"),
    ("25.0,60.1,24.9,60.2", "needs west < east and south < north (the order is W,S,E,N)"),
    ("24.9,60.2,25.0,60.1", "needs west < east and south < north"),
    ("60.1,24.9,60.2,95.0", "north = 95 is outside [-90, 90] degrees"),
    ("-190,0,10,10", "west = -190 is outside [-180, 180] degrees"),
])
def test_a_bad_box(extract, tmp_path, capsys, bbox, message) -> None:
    (line,) = _refused([str(extract), f"--bbox={bbox}", "--out", str(tmp_path / "x.toml")], capsys)
    assert line.startswith(PROG) and message in line
    assert not list(tmp_path.iterdir())


def test_a_box_beyond_the_data_or_with_nothing_in_it(extract, tmp_path, capsys) -> None:
    beyond = _box((-50.0, -50.0, DATA_M[2] + 100.0, 250.0))
    (line,) = _refused([str(extract), f"--bbox={beyond}", "--out", str(tmp_path / "x.toml")], capsys)
    assert f"--bbox {beyond}: reaches beyond the data of town.osm" in line and "from its header" in line
    empty = _box((450.0, -50.0, 550.0, 50.0))
    (line,) = _refused([str(extract), f"--bbox={empty}", "--out", str(tmp_path / "x.toml")], capsys)
    assert f"--bbox {empty}: no buildings and no drivable roads in this box of town.osm" in line
    assert not list(tmp_path.iterdir())


def test_a_missing_or_unreadable_file_and_a_bad_out(extract, tmp_path, capsys) -> None:
    (line,) = _refused([str(tmp_path / "nowhere.osm.pbf"), f"--bbox={GOOD}", "--out", str(tmp_path / "x.toml")], capsys)
    assert line == f"{PROG}FILE {tmp_path / 'nowhere.osm.pbf'}: no such file"
    junk = tmp_path / "junk.osm.pbf"
    junk.write_bytes(b"not protobuf at all" * 10)
    (line,) = _refused([str(junk), f"--bbox={GOOD}", "--out", str(tmp_path / "x.toml")], capsys)
    assert f"{junk}: not a readable OSM file" in line
    (line,) = _refused([str(extract), f"--bbox={GOOD}", "--out", str(tmp_path / "x.json")], capsys)
    assert "--out" in line and "give a .toml file name" in line
    (line,) = _refused([str(extract), f"--bbox={GOOD}", "--out", str(tmp_path / "my city.toml")], capsys)
    assert "letters, digits, _ and - only" in line
    (line,) = _refused([str(extract), f"--bbox={GOOD}", "--out", str(tmp_path / "no" / "x.toml")], capsys)
    assert "no folder" in line
    (line,) = _refused([str(extract), f"--bbox={GOOD}", "--out", str(tmp_path / "x.toml"), "--origin", "91,24"], capsys)
    assert "--origin 91,24: latitude must be in [-90, 90]" in line
    (line,) = _refused([str(extract), "--out", str(tmp_path / "x.toml")], capsys)
    assert "--bbox" in line and "required" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["junk.osm.pbf"]


def test_without_pyosmium_the_command_says_how_to_install_it(extract, tmp_path) -> None:
    code = ("import sys\nsys.modules['osmium'] = None  # as if not installed: importing it raises ImportError\n"
            "from gcs.cli import main\n"
            f"sys.exit(main(['scenario', 'from-osm', {str(extract)!r}, '--bbox={GOOD}', '--out', "
            f"{str(tmp_path / 'x.toml')!r}]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip() == f"{PROG}reading OpenStreetMap files needs pyosmium: pip install 'uav-tracking-gcs[osm]'"


def test_the_scenario_command_line_loads_pyosmium_only_to_read_a_file(tmp_path) -> None:
    code = ("import sys\nfrom gcs.cli import main\n"
            "try:\n    main(['scenario', 'from-osm', '--help'])\nexcept SystemExit as stop:\n    assert stop.code == 0\n"
            "print('osmium' in sys.modules, file=sys.stderr)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stderr.strip().splitlines()[-1] == "False", done.stderr


def test_the_same_town_from_pbf_without_a_header_box_is_framed_by_its_nodes(tmp_path, capsys) -> None:
    source = write_pbf(tmp_path / "town.osm.pbf", bounds=False)
    # the box reaches 50 m west and south of the westernmost and southernmost nodes: beyond this file's data
    (line,) = _refused([str(source), f"--bbox={GOOD}", "--out", str(tmp_path / "x.toml")], capsys)
    assert "reaches beyond the data of town.osm.pbf" in line and "from its nodes" in line
    inner = _box((0.0, 0.0, 250.0, 230.0))
    assert main(["scenario", "from-osm", str(source), f"--bbox={inner}", "--out", str(tmp_path / "x.toml")]) == 0
