"""The emulator core over a whole site: behaviours from config, presence, bodies."""

from __future__ import annotations

import pytest

from services.building.emulator import Building
from shared.codec import decode, encode
from shared.config import load
from shared.messages import (
    BuildingBodies,
    DoorMode,
    DoorRequest,
    LiftDoor,
    LiftRequest,
    LiftRequestType,
)
from shared.site import Door, load_site
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_rooms")


def building(*overrides: str) -> Building:
    return Building(SITE, load(None, list(overrides)).building)


def test_unscripted_manual_door_stands_open() -> None:
    b = building()
    b.update(0.1)
    assert b.doors["door_ab"].mode() == DoorMode.OPEN


def test_scheduled_manual_door_opens_at_its_time() -> None:
    b = building("building.doors={door_ab: {motion: hinged, schedule: [{at_s: 20, action: open}]}}")
    b.update(19.9)
    assert b.doors["door_ab"].mode() == DoorMode.CLOSED
    b.request_door(5.0, DoorRequest(5.0, "chair1", "door_ab", DoorMode.OPEN))  # ignored: manual
    b.update(20.5)
    assert b.doors["door_ab"].mode() == DoorMode.MOVING
    b.update(24.0)
    assert b.doors["door_ab"].mode() == DoorMode.OPEN


def test_automatic_door_follows_the_chair() -> None:
    site = load_site(ROOT / "sites" / "two_rooms")
    site.doors[0] = Door("door_ab", "1", (6.2, 2.2), (6.2, 3.2), "automatic")
    b = Building(
        site,
        load(
            None, ["building.hold_open_s=3", "building.doors={door_ab: {motion: hinged}}"]
        ).building,
    )
    b.chair(1.0, 2.0, 2.7, "1", 0.5)  # far away, moving
    b.update(2.0)
    assert b.doors["door_ab"].opening == 0.0
    b.chair(2.0, 5.2, 2.7, "1", 0.0)  # near, standing still
    b.update(3.0)
    assert b.doors["door_ab"].opening == 0.0
    b.chair(3.0, 5.2, 2.7, "1", 0.1)  # near and moving: opens (about 3.1 s for 90 deg)
    b.chair(6.5, 5.3, 2.7, "1", 0.1)
    b.chair(7.0, 5.3, 2.7, "1", 0.0)  # stops: the hold time runs from here
    b.update(9.9)
    assert b.doors["door_ab"].mode() == DoorMode.OPEN
    b.update(14.0)  # hold time (3 s) over and closed again
    assert b.doors["door_ab"].mode() == DoorMode.CLOSED


def test_states_on_change_and_bodies_message() -> None:
    b = building("building.doors={door_ab: {start_open: false}}")
    b.update(0.0)
    first = b.changed_states(0.0)
    assert [s.door_name for s in first] == ["door_ab"]
    assert b.changed_states(0.1) == []
    msg = decode(encode(b.bodies(0.1)), BuildingBodies)
    assert msg.doors == ["door_ab"] and msg.door_openings.tolist() == [0.0]


def test_config_for_an_unknown_door_is_refused() -> None:
    with pytest.raises(ValueError, match="building.doors.door_zz: no such door"):
        building("building.doors={door_zz: {start_open: true}}")


def test_a_busy_lift_is_held_by_another_user_until_its_time() -> None:
    site = load_site(ROOT / "sites" / "two_floors")
    b = Building(site, load(None, ["building.lifts={lift_b: {busy_until_s: 20}}"]).building)
    ours = LiftRequest(1.0, "lift_b", "chair1-g1", LiftRequestType.AGV_MODE, "1", LiftDoor.OPEN)
    assert "busy" in b.request_lift(1.0, ours)
    assert b.lifts["lift_b"].session_id == "another-user"
    b.update(20.0)
    assert b.lifts["lift_b"].session_id == ""
    assert b.request_lift(20.5, ours) is None
    assert b.lifts["lift_a"].session_id == ""  # the other lift was never busy
