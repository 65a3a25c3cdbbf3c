"""The parameter protocol of a simulated autopilot: PARAM_REQUEST_LIST, PARAM_REQUEST_READ and PARAM_SET.

Every parameter is a REAL32 in ``params`` (name -> value, in the order they are
listed). A PARAM_SET of a known, finite value is stored and echoed as PARAM_VALUE,
as ArduPilot's ``GCS_MAVLINK::handle_param_set`` and PX4's parameter manager do;
an unknown name gets no reply. The names in ``read_only`` (the system id) are
echoed unchanged.
"""

from __future__ import annotations

import math

from gcs.adapters.mavlink_wire import mavlink
from sim_vehicles.telemetry_messages import param_name

__all__ = ["ParameterTable"]


class ParameterTable:
    """Mixin: ``self.params`` and ``self.encoder`` are set by the autopilot; ``_param_changed`` reacts to a set."""

    params: dict[str, float]
    encoder: mavlink.MAVLink
    read_only: frozenset[str] = frozenset({"SYSID_THISMAV", "MAV_SYS_ID"})

    def _param_changed(self, name: str, value: float) -> None:
        """Apply a parameter that was just set (nothing by default)."""

    def _param_value(self, name: str) -> object:
        names = list(self.params)
        return self.encoder.param_value_encode(name.encode("ascii"), self.params[name],
                                               mavlink.MAV_PARAM_TYPE_REAL32, len(names), names.index(name))

    def _on_param_request_list(self, msg, now_s: float, state) -> list:
        return [self._param_value(name) for name in self.params]

    def _on_param_request_read(self, msg, now_s: float, state) -> list:
        names = list(self.params)
        name = param_name(msg.param_id)
        if msg.param_index >= 0:
            name = names[msg.param_index] if msg.param_index < len(names) else ""
        return [self._param_value(name)] if name in self.params else []

    def _on_param_set(self, msg, now_s: float, state) -> list:
        name = param_name(msg.param_id)
        if name not in self.params:
            return []
        if math.isfinite(msg.param_value) and name not in self.read_only:
            self.params[name] = float(msg.param_value)
            self._param_changed(name, float(msg.param_value))
        return [self._param_value(name)]
