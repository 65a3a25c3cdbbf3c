"""Bad input to ``gcs-bench``: one line on stderr naming the bad value and the fix, status 2, as for ``gcs``.

The table runs ``benchmarks.cli.main`` on invocations refused before any benchmark starts; the Hypothesis
test feeds random option lists to a few benchmarks' parsers and input checks (the harness of
``tests/unit/test_cli_errors.py``).
"""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchmarks import cli
from gcs.cli_errors import run_command
from gcs.config import ScenarioError
from tests.unit.test_cli_errors import VALUES, WORK, _refused, _subparser, files  # noqa: F401 (files: a fixture)

TABLE = [
    (["estimation", "--json", f"{WORK}/x.json"], "gcs-bench estimation", f"no folder {WORK}"),
    (["estimation", "--runs", "0"], "gcs-bench estimation", "argument --runs: must be >= 1"),
    (["urban", "--scenario", "nosuch"], "gcs-bench urban", "unknown scenario 'nosuch'"),
    (["soak", "--vehicles", "2", "--workdir", "{folder}/soak"], "gcs-bench soak",
     "--vehicles must be at least the scenario's 3"),
    (["soak", "--plots", "{recording}"], "gcs-bench soak", "--plots"),
    (["demo", "--runs", "0"], "gcs-bench demo", "--runs"),
    (["autopilots", "--autopilot", "betaflight"], "gcs-bench autopilots", "invalid choice: 'betaflight'"),
    (["roads", "--seeds", "0"], "gcs-bench roads", "--seeds 0"),
    (["roads", "--scenarios", "nosuch"], "gcs-bench roads", "--scenarios 'nosuch'"),
    (["nosuch"], "gcs-bench", "argument COMMAND: invalid choice: 'nosuch'"),
]


@pytest.mark.parametrize("argv, prefix, message", TABLE, ids=[" ".join(row[0]) for row in TABLE])
def test_bad_input_is_one_line_naming_it_and_status_2(files, capsys, argv, prefix, message) -> None:
    argv = [arg.format(**files) for arg in argv]
    code, lines = _refused(cli.main, argv, capsys)
    assert code == 2, lines
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"{prefix}: error: ") and message.format(**files) in lines[0], lines[0]


@pytest.mark.parametrize("bench", ["soak", "urban", "estimation", "multitarget"])
def test_random_input_to_a_benchmarks_parser_and_check_is_refused_in_one_line_or_taken(files, capsys, bench) -> None:
    parser = _subparser(cli.build_parser(bench), [bench])
    options = [s for a in parser._actions for s in a.option_strings if s not in {"-h", "--help"}]
    values = st.sampled_from(VALUES + [str(p) for p in files.values()]) | st.text(max_size=12)
    argv_strategy = st.lists(st.tuples(st.sampled_from(options), values).map(list), max_size=5).map(
        lambda parts: [bench, *[token for part in parts for token in part]])

    @settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
    @given(argv=argv_strategy)
    def check(argv: list[str]) -> None:
        try:
            args = cli.build_parser(bench).parse_args(argv)
        except SystemExit as stop:
            lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
            assert stop.code == 2 and len(lines) == 1 and ": error: " in lines[0], (argv, lines)
            return
        args.handler = lambda parsed: (parsed.check(parsed), 0)[1]  # the benchmark's checks, nothing started
        code = run_command(args, known=(ScenarioError,))
        lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
        assert (code, lines) == (0, []) or (code == 2 and len(lines) == 1 and re.match(r"[\w -]+: error: ",
                                                                                        lines[0])), (argv, lines)

    check()


def test_the_listing_shows_each_benchmarks_own_help_line() -> None:
    # gcs-bench --help imports no benchmark: its help lines are a copy, held equal to the parsers' own here
    import argparse

    def help_lines(parser) -> dict[str, str]:
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        return {choice.dest: choice.help for choice in action._choices_actions}

    assert help_lines(cli.COMMAND_LINE.listing_parser()) == help_lines(cli.build_parser())
