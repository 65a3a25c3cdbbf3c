"""``python -m benchmarks.roads``: ``gcs-bench roads`` (:mod:`benchmarks.roads.command`) without the console script."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from benchmarks.roads.command import add_arguments, check, run
from gcs.cli_errors import OneLineParser, run_command, set_command


def main(argv: Sequence[str] | None = None) -> int:
    parser = OneLineParser(prog="python -m benchmarks.roads", description="The road trackers against the "
                           "scenario's estimator, open loop, paired seeds (gcs-bench roads).")
    add_arguments(parser)
    set_command(parser, run, check)
    return run_command(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
