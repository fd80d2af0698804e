"""The mission report's diagnostics: each service's latest counters before the end."""

from __future__ import annotations

import numpy as np

from shared.messages import Diagnostics, KeyCounters, NavStatus, Path, RouteReply
from wheelnav.mission.report import Recorder, format_report


def diag(service: str, n_in: int, bad: int, restarts: int = 0) -> Diagnostics:
    keys = [KeyCounters("wheelnav/chair1/odom", n_in - 1, bad), KeyCounters("x/y", 1, 0)]
    return Diagnostics(1.7e9, service, 7, restarts, 1.0, n_in, bad, keys)


def test_report_shows_the_latest_counters_per_service_until_the_mission_ends() -> None:
    rec = Recorder("g1")
    rec.on_status(NavStatus(0.0, "g1", "running"))
    rec.on_diagnostics(diag("controller", 10, 0))
    rec.on_diagnostics(diag("controller", 50, 3, restarts=1))
    rec.on_diagnostics(diag("building", 5, 0))
    rec.on_status(NavStatus(9.0, "g1", "succeeded", reason="arrived"))
    rec.on_diagnostics(diag("controller", 99, 9))  # after the end: not the mission's
    report = rec.report("demo", 1.0)
    assert list(report["diagnostics"]) == ["building", "controller"]
    assert report["diagnostics"]["controller"] == {
        "messages_in": 50,
        "bad_messages": 3,
        "restarts": 1,
        "bad_by_key": {"wheelnav/chair1/odom": 3},
    }
    assert report["diagnostics"]["building"]["bad_by_key"] == {}
    text = format_report(report)
    assert "diagnostics controller" in text and "bad     3  restarts 1" in text
    assert "(wheelnav/chair1/odom 3)" in text


def test_a_report_without_diagnostics_still_formats() -> None:
    report = Recorder("g").report("demo", 1.0)
    assert report["diagnostics"] == {}
    assert "diagnostics" not in format_report(report)


def test_the_first_routes_length_is_kept_past_a_re_plan() -> None:
    rec = Recorder("g")

    def leg(x0: float) -> Path:
        return Path(0.0, "leg", "1", np.array([(x0, 0.0), (10.0, 0.0)]), np.array([0.5, 0.0]))

    rec.on_route(RouteReply(True, legs=[leg(0.0)]))
    rec.on_route(RouteReply(True, legs=[leg(8.0)]))  # after a recovery near the goal
    report = rec.report("demo", 1.0)
    assert report["first_planned_length_m"] == 10.0
    assert report["planned_length_m"] == 2.0
