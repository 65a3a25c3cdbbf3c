"""Bad command-line input, for every command: one line on stderr naming the bad value and the fix, status 2.

The table runs each command's entry point (``gcs.cli.main``, ``sim_vehicles.cli.main``) on an invocation
that must be refused before anything starts, and checks the status and the one line. The Hypothesis test
feeds random option lists to every parser and to each command's check of its input (what the command runs
before it opens anything) and asserts that nothing escapes but a one-line refusal.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import gcs.cli
import sim_vehicles.cli
from gcs.adapters.recording import Recorder
from gcs.cli_errors import run_command, stop_on_signals
from gcs.config import ScenarioError

WORK = Path("/nonexistent-gcs-test-folder")
"""A folder that does not exist: files under it cannot be written or read."""


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """A real (empty, finished) recording, files that are not recordings, a bad scenario."""
    folder = tmp_path_factory.mktemp("cli")
    paths = {"recording": folder / "run.mcap", "junk": folder / "junk.mcap", "toml": folder / "s.mcap",
             "empty": folder / "empty.mcap", "scenario": folder / "bad.toml", "folder": folder}
    Recorder(paths["recording"]).finish()
    paths["junk"].write_bytes(b"junk")
    paths["toml"].write_text("[origin]\nlat_deg = 1.0\n")
    paths["empty"].write_bytes(b"")
    paths["scenario"].write_text("[origin]\nlat_deg = 1.0\n")
    return paths


def _refused(main, argv: list[str], capsys) -> tuple[int, list[str]]:
    """Run an entry point; its status (argparse's exit included) and the non-empty lines it wrote to stderr."""
    try:
        code = main(argv)
    except SystemExit as stop:
        code = stop.code
    err = capsys.readouterr().err
    return code, [line for line in err.splitlines() if line.strip()]


# (program, argv with {name} for the fixture's files, the command's prefix, what the line must say)
TABLE = [
    ("gcs", ["run", "--mavlink", "bogus:xyz"], "gcs run", "--mavlink: MAVLink connection 'bogus:xyz': unknown scheme"),
    ("gcs", ["run", "--mavlink", "udpin:127.0.0.1:99999"], "gcs run", "port 99999 is outside 0-65535"),
    ("gcs", ["run", "--mavlink", "udpin:no-such-host.invalid:14550"], "gcs run",
     "host 'no-such-host.invalid' does not resolve"),
    ("gcs", ["run", "--mavlink", "tcp:127.0.0.1"], "gcs run", "expected tcp:HOST:PORT"),
    ("gcs", ["run", "--vehicle", "uav1=udpin:127.0.0.1:x"], "gcs run", "port 'x' is not a number"),
    ("gcs", ["run", "--vehicle", "nobody=udpin:127.0.0.1:0"], "gcs run", "--vehicle names unknown vehicles ['nobody']"),
    ("gcs", ["run", "--record", f"{WORK}/x.mcap"], "gcs run", f"--record {WORK}/x.mcap: no folder {WORK}"),
    ("gcs", ["run", "--record", "{folder}"], "gcs run", "is a folder; give a file name"),
    ("gcs", ["run", "--zenoh-listen", "bogus"], "gcs run", "--zenoh-listen: zenoh endpoint 'bogus': expected "
                                                          "PROTOCOL/HOST:PORT"),
    ("gcs", ["run", "--zenoh-listen", "tcp/127.0.0.1:99999"], "gcs run", "port 99999 is outside 0-65535"),
    ("gcs", ["run", "--zenoh-connect", "tcp/127.0.0.1:0"], "gcs run", "port 0 is outside 1-65535"),
    ("gcs", ["run", "--zenoh-listen", "tcp/no-such-host.invalid:7447"], "gcs run", "does not resolve"),
    ("gcs", ["run", "--zenoh-mode", "client"], "gcs run", "needs at least one --zenoh-connect"),
    ("gcs", ["run", "--zenoh-mode", "none"], "gcs run", "needs zenoh: --zenoh-mode peer or client, not none"),
    ("gcs", ["run", "--zenoh-config", f"{WORK}/z.json5"], "gcs run", "no such file"),
    ("gcs", ["run", "--scenario", "nosuch"], "gcs run", "unknown scenario 'nosuch'"),
    ("gcs", ["run", "--scenario", "{scenario}"], "gcs run", "missing required field `lon_deg`"),
    ("gcs", ["run", "--prefix", "a b"], "gcs run", "--prefix: invalid key prefix 'a b'"),
    ("gcs", ["run", "--signing-key-file", f"{WORK}/key"], "gcs run", f"--signing-key-file {WORK}/key"),
    ("gcs", ["run", "--planner", "nosuch"], "gcs run", "argument --planner: invalid choice: 'nosuch'"),
    ("gcs", ["run", "--scenario", "multitarget_urban", "--planner", "orbit"], "gcs run",
     "--planner: orbit cannot share the UAVs between the targets of multitarget_urban ([multitarget]); use one of "
     "sight, sight_k0"),
    ("gcs", ["run", "--scenario", "multitarget_urban", "--federation", "city", "--member", "west", "--area",
             "0,0,1000"], "gcs run", "--area '0,0,1000': not four finite numbers; give X_MIN,Y_MIN,X_MAX,Y_MAX"),
    ("gcs", ["run", "--scenario", "multitarget_urban", "--federation", "city", "--member", "west", "--area",
             "1000,0,0,3000"], "gcs run", "--area '1000,0,0,3000': empty area; give X_MIN,Y_MIN,X_MAX,Y_MAX in metres "
                                          "with X_MIN < X_MAX"),
    ("gcs", ["run", "--scenario", "multitarget_urban", "--federation", "city", "--area", "0,0,1000,3000"], "gcs run",
     "--member missing: --federation, --member and --area go together"),
    ("gcs", ["run", "--scenario", "multitarget_urban", "--member", "west"], "gcs run",
     "--federation, --area missing: --federation, --member and --area go together"),
    ("gcs", ["run", "--scenario", "multitarget_urban", "--federation", "city", "--member", "west/1", "--area",
             "0,0,1,1"], "gcs run", "--member: invalid member id 'west/1'"),
    ("gcs", ["run", "--federation", "city", "--member", "west", "--area", "0,0,1000,3000"], "gcs run",
     "--federation: scenario wang2012_urban tracks one target; a federation member tracks many: use a scenario with "
     "[multitarget]"),
    ("gcs", ["run", "--scenario", "multitarget_urban", "--federation", "city", "--member", "west", "--area",
             "0,0,1,1", "--fusion", "mean"], "gcs run", "argument --fusion: invalid choice: 'mean'"),
    ("gcs", ["status", "--federation", "a b"], "gcs status", "--federation: invalid key prefix 'a b'"),
    ("gcs", ["record", "-o", "{folder}/x.mcap", "--federation", "a/"], "gcs record",
     "--federation: invalid key prefix 'a/'"),
    ("gcs", ["replay", "{recording}", "--info", "--federation", "city"], "gcs replay",
     "--federation replays a federation member's engine: add --process"),
    ("gcs", ["run", "--stream-rate", "90"], "gcs run", "--stream-rate must be between 0 and 50 Hz, got 90"),
    ("gcs", ["run", "--stream-rate", "x"], "gcs run", "argument --stream-rate: invalid float value: 'x'"),
    ("gcs", ["run", "--takeover-altitude", "nan"], "gcs run", "--takeover-altitude must be a height in metres"),
    ("gcs", ["run", "--handback", "LAND"], "gcs run", "argument --handback: invalid choice: 'LAND'"),
    ("gcs", ["run", "--handback-after", "0"], "gcs run", "--handback-after must be a finite number > 0, got 0"),
    ("gcs", ["demo", "--handback-after", "-5"], "gcs demo", "--handback-after must be a finite number > 0"),
    ("gcs", ["run", "--http", "nonsense"], "gcs run", "--http wants HOST:PORT"),
    ("gcs", ["demo", "--duration", "-5"], "gcs demo", "--duration must be a finite number > 0, got -5"),
    ("gcs", ["demo", "--rate", "nan"], "gcs demo", "--rate must be a finite number > 0, got nan"),
    ("gcs", ["demo", "--scenario", "nosuch"], "gcs demo", "unknown scenario 'nosuch'"),
    ("gcs", ["status", "--timeout", "0"], "gcs status", "--timeout must be a finite number > 0, got 0"),
    ("gcs", ["status", "--zenoh-connect", "udp"], "gcs status", "zenoh endpoint 'udp': expected PROTOCOL/HOST:PORT"),
    ("gcs", ["status", "--prefix", "/gcs"], "gcs status", "--prefix: invalid key prefix '/gcs'"),
    ("gcs", ["record"], "gcs record", "the following arguments are required: -o/--output"),
    ("gcs", ["record", "-o", f"{WORK}/x.mcap"], "gcs record", f"--output {WORK}/x.mcap: no folder {WORK}"),
    ("gcs", ["record", "-o", "{folder}/x.mcap", "--duration", "-3"], "gcs record", "--duration must be"),
    ("gcs", ["record", "-o", "{folder}/x.mcap", "--zenoh-mode", "none"], "gcs record", "gcs record needs zenoh"),
    ("gcs", ["replay", f"{WORK}/x.mcap", "--info"], "gcs replay", f"FILE {WORK}/x.mcap: no such file"),
    ("gcs", ["replay", "{junk}", "--info"], "gcs replay", "not an MCAP recording"),
    ("gcs", ["replay", "{toml}", "--process"], "gcs replay", "not an MCAP recording"),
    ("gcs", ["replay", "{empty}", "--info"], "gcs replay", "the file is empty"),
    ("gcs", ["replay", "{folder}", "--info"], "gcs replay", "not a file"),
    ("gcs", ["replay", "{recording}", "--rate", "0"], "gcs replay", "--rate must be a finite number > 0"),
    ("gcs", ["replay", "{recording}", "--process", "--out", f"{WORK}/t.csv"], "gcs replay", "--out"),
    ("gcs", ["replay", "{recording}", "--view", "--http", "none"], "gcs replay", "--view needs --http ADDRESS"),
    ("gcs", ["replay", "{recording}", "--foxglove", "127.0.0.1:0"], "gcs replay", "--foxglove serves a replay live"),
    ("gcs", ["replay", "{recording}", "--view", "--info", "--http", "127.0.0.1:0"], "gcs replay",
     "cannot be combined with --info"),
    ("gcs", ["replay", "{recording}", "--process", "--scenario", "nosuch"], "gcs replay", "unknown scenario"),
    ("gcs", ["router", "--zenoh-listen", "tcp/127.0.0.1:99999"], "gcs router", "port 99999 is outside 0-65535"),
    ("gcs", ["router", "--zenoh-mode", "none"], "gcs router", "a router needs zenoh"),
    ("gcs", ["scenario", "check", "nosuch"], "gcs scenario", "unknown scenario 'nosuch'"),
    ("gcs", ["scenario", "show", "{scenario}"], "gcs scenario", "missing required field `lon_deg`"),
    ("gcs", ["bench", "urban", "--runs", "3"], "gcs",
     "the benchmarks are a command of their own: gcs-bench urban --runs 3"),
    ("gcs", ["--log-level", "ERROR", "bench"], "gcs", "a command of their own: gcs-bench --help"),
    ("gcs", ["nosuch"], "gcs", "argument COMMAND: invalid choice: 'nosuch'"),
    ("sim-vehicles", ["run", "--mavlink", "bogus:xyz"], "sim-vehicles run", "unknown scheme 'bogus'"),
    ("sim-vehicles", ["run", "--mavlink", "udpin:127.0.0.1:99999"], "sim-vehicles run", "port 99999 is outside"),
    ("sim-vehicles", ["run", "--zenoh-connect", "bogus"], "sim-vehicles run", "zenoh endpoint 'bogus'"),
    ("sim-vehicles", ["run", "--rate", "0"], "sim-vehicles run", "--rate must be a finite number > 0, got 0"),
    ("sim-vehicles", ["run", "--duration", "inf"], "sim-vehicles run", "--duration must be a finite number > 0"),
    ("sim-vehicles", ["run", "--only", "nobody"], "sim-vehicles run", "--only nobody: not in the scenario"),
    ("sim-vehicles", ["run", "--json", f"{WORK}/s.json"], "sim-vehicles run", f"--json {WORK}/s.json: no folder"),
    ("sim-vehicles", ["run", "--lockstep", "--zenoh-mode", "none"], "sim-vehicles run", "not with --zenoh-mode none"),
    ("sim-vehicles", ["run", "--wait-for-plans", "--zenoh-mode", "none"], "sim-vehicles run",
     "--wait-for-plans hears the plans over zenoh: not with --zenoh-mode none"),
    ("sim-vehicles", ["run", "--wait-for-gcs", "-1"], "sim-vehicles run", "--wait-for-gcs must be"),
    ("sim-vehicles", ["run", "--start-at", "1e20"], "sim-vehicles run", "--start-at is a Unix time in seconds"),
    ("sim-vehicles", ["run", "--only", "uav1", "--start-with", "uav1"], "sim-vehicles run",
     "--start-with uav1: not a vehicle of the scenario flown by another process (uav2, uav3)"),
    ("sim-vehicles", ["run", "--start-with", "uav2"], "sim-vehicles run",
     "--start-with uav2: not a vehicle of the scenario flown by another process (none: this process flies all)"),
    ("sim-vehicles", ["run", "--only", "uav1", "--start-with", "uav2", "--start-at", "0"], "sim-vehicles run",
     "--start-with and --start-at both say when the clock starts: give one"),
    ("sim-vehicles", ["run", "--only", "uav1", "--start-with", "uav2", "--zenoh-mode", "none"], "sim-vehicles run",
     "--start-with hears the other vehicles over zenoh: not with --zenoh-mode none"),
    ("sim-vehicles", ["run", "--scenario", "nosuch"], "sim-vehicles run", "unknown scenario 'nosuch'"),
    ("sim-vehicles", ["payload"], "sim-vehicles payload", "give at least one --vehicle ID=CONNECTION"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1"], "sim-vehicles payload",
     "--vehicle 'uav1': expected ID=CONNECTION, e.g. uav1=udpin:127.0.0.1:14551"),
    ("sim-vehicles", ["payload", "--vehicle", "nobody=udpin:127.0.0.1:0"], "sim-vehicles payload",
     "--vehicle nobody: not in the scenario, whose vehicles are uav1, uav2, uav3"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpin:127.0.0.1:0", "--vehicle", "uav1=udpin:127.0.0.1:0"],
     "sim-vehicles payload", "--vehicle uav1: given twice"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=bogus:xyz"], "sim-vehicles payload",
     "--vehicle uav1: MAVLink connection 'bogus:xyz': unknown scheme 'bogus'"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpin:127.0.0.1:99999"], "sim-vehicles payload",
     "port 99999 is outside 0-65535"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpout:127.0.0.1:0"], "sim-vehicles payload",
     "port 0 is outside 1-65535"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=tcp:127.0.0.1"], "sim-vehicles payload",
     "expected tcp:HOST:PORT"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpin:127.0.0.1:0", "--zenoh-mode", "none"],
     "sim-vehicles payload", "needs zenoh: --zenoh-mode peer or client, not none"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpin:127.0.0.1:0", "--zenoh-connect", "bogus"],
     "sim-vehicles payload", "--zenoh-connect: zenoh endpoint 'bogus'"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpin:127.0.0.1:0", "--stale-after", "0"],
     "sim-vehicles payload", "--stale-after must be a finite number > 0, got 0"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpin:127.0.0.1:0", "--request-rate", "500"],
     "sim-vehicles payload", "--request-rate 500: at most 50 Hz"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpin:127.0.0.1:0", "--duration", "nan"],
     "sim-vehicles payload", "--duration must be a finite number > 0, got nan"),
    ("sim-vehicles", ["payload", "--vehicle", "uav1=udpin:127.0.0.1:0", "--prefix", "a b"], "sim-vehicles payload",
     "--prefix: invalid key prefix 'a b'"),
    ("sim-vehicles", ["payload", "--scenario", "nosuch"], "sim-vehicles payload", "unknown scenario 'nosuch'"),
]

MAINS = {"gcs": gcs.cli.main, "sim-vehicles": sim_vehicles.cli.main}


@pytest.mark.parametrize("program, argv, prefix, message", TABLE, ids=[" ".join(row[1]) for row in TABLE])
def test_bad_input_is_one_line_naming_it_and_status_2(files, capsys, program, argv, prefix, message) -> None:
    argv = [arg.format(**files) for arg in argv]
    code, lines = _refused(MAINS[program], argv, capsys)
    assert code == 2, lines
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"{prefix}: error: ") and message.format(**files) in lines[0], lines[0]
    assert "Traceback" not in lines[0]


# ------------------------------------------------------------------ random input


def _subparser(parser: argparse.ArgumentParser, path: list[str]) -> argparse.ArgumentParser:
    for name in path:
        action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = action.choices[name]
    return parser


COMMANDS = [("gcs", ["run"]), ("gcs", ["demo"]), ("gcs", ["status"]), ("gcs", ["record"]), ("gcs", ["router"]),
            ("gcs", ["replay"]), ("gcs", ["scenario", "check"]), ("sim-vehicles", ["run"]),
            ("sim-vehicles", ["payload"])]
PARSERS = {"gcs": gcs.cli.build_parser, "sim-vehicles": sim_vehicles.cli.build_parser}
NEVER = {"-h", "--help", "--version"}
VALUES = ["", "0", "-1", "1", "2.5", "nan", "inf", "-inf", "1e400", "none", "bogus", "bogus:xyz", "a b", "uav1",
          "udpin:127.0.0.1:0", "udpout:127.0.0.1:99999", "tcp:127.0.0.1", "udpin:no-such-host.invalid:1",
          "tcp/127.0.0.1:0", "tcp/127.0.0.1:70000", "udp", "tls/x", "uav1=udpin:127.0.0.1:0", "nobody=udp:1",
          str(WORK / "x"), "wang2012_urban", "nosuch", "127.0.0.1:0", "ga_k5", "orbit"]


def _argv_strategy(program: str, path: list[str], files: dict[str, Path]):
    parser = _subparser(PARSERS[program](), path)
    options = [s for a in parser._actions for s in a.option_strings if s not in NEVER]
    values = st.sampled_from(VALUES + [str(p) for p in files.values()]) | st.text(max_size=12)
    option = st.tuples(st.sampled_from(options), values).map(list) if options else st.nothing()
    positional = [str(files["recording"])] if path == ["replay"] else []
    return st.lists(option | st.lists(values, max_size=1), max_size=5).map(
        lambda parts: [*path, *positional, *[token for part in parts for token in part]])


@pytest.mark.parametrize("program, path", COMMANDS, ids=[" ".join([p, *c]) for p, c in COMMANDS])
def test_random_input_to_every_parser_and_check_is_refused_in_one_line_or_taken(files, capsys, program,
                                                                                path) -> None:
    @settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
    @given(argv=_argv_strategy(program, path, files))
    def check(argv: list[str]) -> None:
        try:
            args = PARSERS[program]().parse_args(argv)
        except SystemExit as stop:
            lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
            assert stop.code == 2 and len(lines) == 1 and ": error: " in lines[0], (argv, lines)
            return
        if getattr(args, "check", None) is None:
            return  # nothing to check beyond the parser (a command that takes no input but its options)
        args.handler = lambda parsed: (parsed.check(parsed), 0)[1]  # the command's checks, nothing started
        code = run_command(args, known=(ScenarioError,))  # anything else escapes and fails the test
        lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
        assert (code, lines) == (0, []) or (code == 2 and len(lines) == 1 and re.match(r"[\w -]+: error: ",
                                                                                        lines[0])), (argv, lines)

    check()


# ------------------------------------------------------------------ Ctrl-C


def _stops_itself(signum: int, status: int):
    """A command that stops on signals, receives ``signum`` while it runs, finishes and returns ``status``."""
    def handler(args: argparse.Namespace) -> int:
        stopped = []
        restore = stop_on_signals(lambda: stopped.append(True))
        try:
            os.kill(os.getpid(), signum)
            assert stopped == [True]  # the handler ran: the command's loop was asked to return
        finally:
            restore()
        return status
    return handler


@pytest.mark.parametrize(("signum", "status", "expected"), [(signal.SIGINT, 0, 130), (signal.SIGTERM, 0, 143),
                                                            (signal.SIGINT, 1, 1)])
def test_a_command_stopped_by_a_signal_says_interrupted_and_exits_128_plus_its_number(capsys, signum, status,
                                                                                      expected) -> None:
    before = signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)
    args = argparse.Namespace(handler=_stops_itself(signum, status), command_prog="gcs run")
    assert run_command(args) == expected  # a failure of its own (1) is not hidden behind the interruption
    assert capsys.readouterr().err.splitlines() == ["gcs run: interrupted"]
    assert (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)) == before  # the previous handlers are back


def test_ctrl_c_without_a_handler_is_one_line_and_130(capsys) -> None:
    def handler(args: argparse.Namespace) -> int:
        raise KeyboardInterrupt

    assert run_command(argparse.Namespace(handler=handler, command_prog="gcs replay")) == 130
    assert capsys.readouterr().err.splitlines() == ["gcs replay: interrupted"]
    assert run_command(argparse.Namespace(handler=lambda args: 0, command_prog="gcs scenario")) == 0  # cleared
