"""Typed planning failures, each with a stable code the route reply carries (one table)."""

from __future__ import annotations


class PlanError(Exception):
    """Base of planning failures; ``code`` goes on the wire, the message is one line."""

    code = "PLAN_FAILED"


class UnknownPlace(PlanError):
    code = "UNKNOWN_PLACE"


class UnknownFloor(PlanError):
    code = "UNKNOWN_FLOOR"


class OutsideMap(PlanError):
    code = "OUTSIDE_MAP"


class StartOccupied(PlanError):
    code = "START_OCCUPIED"


class GoalOccupied(PlanError):
    code = "GOAL_OCCUPIED"


class NoPath(PlanError):
    code = "NO_PATH"


class BadRequest(PlanError):
    code = "BAD_REQUEST"


CODES: dict[str, type[PlanError]] = {
    cls.code: cls
    for cls in (
        PlanError,
        UnknownPlace,
        UnknownFloor,
        OutsideMap,
        StartOccupied,
        GoalOccupied,
        NoPath,
        BadRequest,
    )
}
