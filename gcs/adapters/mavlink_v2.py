"""pymavlink with MAVLink 2 selected: ``MAVLINK20=1`` must be set before ``pymavlink.mavutil`` is first imported
(signing needs MAVLink 2). Every module of the project that uses pymavlink imports ``mavutil`` from here, or
through :mod:`gcs.adapters.mavlink_wire`."""

from __future__ import annotations

import os
import sys

if "pymavlink.mavutil" in sys.modules and os.environ.get("MAVLINK20") != "1":  # pragma: no cover
    raise ImportError("pymavlink.mavutil was imported before MAVLINK20=1 was set; import "
                      "gcs.adapters.mavlink_wire first so that MAVLink 2 is selected")
os.environ["MAVLINK20"] = "1"

from pymavlink import mavutil  # noqa: E402

__all__ = ["mavutil"]
