"""Command-line options for MAVLink endpoints and signing, shared by ``gcs`` and ``sim-vehicles``."""

from __future__ import annotations

import argparse
from pathlib import Path

from gcs.adapters.mavlink_wire import check_connection, read_signing_key, signing_key_from_passphrase

__all__ = ["add_mavlink_arguments", "connections_from_arguments", "signing_key_from_arguments"]


def _vehicle_connection(text: str) -> tuple[str, str]:
    vehicle_id, sep, connection = text.partition("=")
    if not sep or not vehicle_id or not connection.strip():
        raise argparse.ArgumentTypeError(f"expected ID=CONNECTION, got {text!r}")
    try:
        return vehicle_id, check_connection(connection)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_mavlink_arguments(parser: argparse.ArgumentParser, default: str, every: str) -> None:
    """``--mavlink``, ``--vehicle ID=CONNECTION`` and the signing options.

    ``every`` completes "pymavlink connection string <every> uses" in the help.
    """
    parser.add_argument("--mavlink", default=default, metavar="CONNECTION",
                        help=f"pymavlink connection string {every} uses (default {default}); 'none' disables MAVLink")
    parser.add_argument("--vehicle", action="append", type=_vehicle_connection, default=[], metavar="ID=CONNECTION",
                        help="a vehicle's own MAVLink endpoint (repeatable), e.g. uav2=udpin:127.0.0.1:14561")
    signing = parser.add_mutually_exclusive_group()
    signing.add_argument("--signing-passphrase", metavar="PASS",
                         help="sign MAVLink 2 with sha256(PASS), as MAVProxy's 'signing key PASS'")
    signing.add_argument("--signing-key-file", type=Path, metavar="FILE",
                         help="sign MAVLink 2 with a 32-byte key (raw or 64 hex characters)")


def connections_from_arguments(args: argparse.Namespace, vehicle_ids: list[str]) -> dict[str, str] | None:
    """Each vehicle's connection string, or None when MAVLink is off; ValueError naming a bad connection or
    vehicle."""
    if args.mavlink.lower() == "none" and not args.vehicle:
        return None
    try:
        default = None if args.mavlink.lower() == "none" else check_connection(args.mavlink)
    except ValueError as error:
        raise ValueError(f"--mavlink: {error}") from None
    overrides: dict[str, str] = dict(args.vehicle)
    unknown = sorted(set(overrides) - set(vehicle_ids))
    if unknown:
        raise ValueError(f"--vehicle names unknown vehicles {unknown}; the scenario has {vehicle_ids}")
    endpoints = {v: overrides[v] if v in overrides else default for v in vehicle_ids}
    missing = [v for v, endpoint in endpoints.items() if endpoint is None]
    if missing:
        raise ValueError(f"--mavlink none leaves {missing} without an endpoint; give --vehicle for each")
    return {v: endpoint for v, endpoint in endpoints.items() if endpoint is not None}


def signing_key_from_arguments(args: argparse.Namespace) -> bytes | None:
    """The signing key the options give, if any; ValueError naming the option when it cannot be had."""
    if args.signing_passphrase is not None:
        try:
            return signing_key_from_passphrase(args.signing_passphrase)
        except ValueError as error:
            raise ValueError(f"--signing-passphrase: {error}") from None
    if args.signing_key_file is not None:
        try:
            return read_signing_key(args.signing_key_file)
        except (OSError, ValueError) as error:
            raise ValueError(f"--signing-key-file {args.signing_key_file}: {getattr(error, 'strerror', None) or error}"
                             ) from None
    return None
