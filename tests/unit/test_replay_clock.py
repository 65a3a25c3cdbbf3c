"""The replay viewer's clock: play, pause, speed and restart, with a fake wall clock."""

from __future__ import annotations

import math

import pytest

from gcs.recordings.replay_view import MAX_SPEED, ReplayClock

NS = 1_000_000_000


class _Wall:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_position_advances_with_wall_time_times_speed_and_stops_while_paused() -> None:
    wall = _Wall()
    clock = ReplayClock(2.0, duration_ns=60 * NS, wall=wall)
    wall.now += 1.5
    assert clock.position_ns() == 3 * NS
    assert clock.control({"action": "pause"})["playing"] is False
    wall.now += 10.0
    assert clock.position_ns() == 3 * NS
    clock.control({"action": "play", "speed": 0.5})
    wall.now += 4.0
    assert clock.position_ns() == 5 * NS
    clock.control({"speed": 10})  # a change of speed does not make the position jump
    assert clock.position_ns() == 5 * NS
    wall.now += 0.1
    assert clock.position_ns() == 6 * NS
    assert clock.view() == {"playing": True, "speed": 10.0, "position_s": 6.0, "duration_s": 60.0, "ended": False}


def test_toggle_restart_and_play_after_the_end() -> None:
    wall = _Wall()
    clock = ReplayClock(1.0, duration_ns=None, wall=wall)
    assert clock.control({"action": "toggle"})["playing"] is False
    assert clock.control({"action": "toggle"})["playing"] is True
    wall.now += 3.0
    clock.finish()
    view = clock.view()
    assert (view["ended"], view["playing"], view["position_s"], view["duration_s"]) == (True, False, 3.0, None)
    assert not clock.take_restart()
    clock.control({"action": "play"})  # at the end, play starts over
    assert clock.take_restart() and not clock.take_restart()
    assert clock.position_ns() == 0 and clock.view()["ended"] is False
    wall.now += 1.0
    clock.control({"action": "restart"})
    assert clock.take_restart() and clock.position_ns() == 0


@pytest.mark.parametrize("request_, message", [
    ({"action": "rewind"}, "action must be"),
    ({"speed": 0}, "speed must be"),
    ({"speed": -1.0}, "speed must be"),
    ({"speed": math.inf}, "speed must be"),
    ({"speed": MAX_SPEED * 2}, "speed must be"),
    ({"speed": "fast"}, "speed must be"),
    ({"speed": True}, "speed must be"),
    ({"volume": 3}, "unknown keys"),
])
def test_bad_controls_are_refused_with_a_reason_and_change_nothing(request_, message) -> None:
    wall = _Wall()
    clock = ReplayClock(1.0, duration_ns=None, wall=wall)
    with pytest.raises(ValueError, match=message):
        clock.control(request_)
    assert clock.view()["speed"] == 1.0 and clock.view()["playing"] is True
