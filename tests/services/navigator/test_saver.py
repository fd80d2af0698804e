"""The navigator's saved mission, taken up after a restart (services/navigator/node.Saver)."""

from __future__ import annotations

import logging

import py_trees
import pytest

from services.navigator.node import Saver
from services.navigator.resume import MissionRecord
from shared.messages import NavGoal
from shared.state_store import StateStore
from tests.behaviours.fleet_fake import ScriptedFleet, door, route
from tests.services.navigator.test_navigator import navigator

LOG = logging.getLogger("test")


@pytest.fixture(autouse=True)
def fresh_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def _saved(tmp_path) -> StateStore:
    store = StateStore(tmp_path, "navigator")
    store.save(MissionRecord(5.0, "g1", None, "room_b", "running", "follow", ["d9"]).to_dict())
    return store


def test_a_saved_running_mission_is_taken_up_with_its_avoided_checkpoints(tmp_path) -> None:
    fleet = ScriptedFleet(route(door()))
    nav, _out = navigator(fleet)
    saver = Saver(nav, _saved(tmp_path), 30.0, LOG)
    assert saver.pending
    saver.take_up(6.0)
    assert not saver.pending and (nav.status.goal_id, nav.status.state) == ("g1", "running")
    assert fleet.avoided == {"d9"}
    saver.save(6.0)
    assert StateStore(tmp_path, "navigator").load()["goal_id"] == "g1"


def test_a_goal_that_came_first_wins_over_the_saved_mission(tmp_path) -> None:
    fleet = ScriptedFleet(route(door()))
    nav, _out = navigator(fleet)
    saver = Saver(nav, _saved(tmp_path), 30.0, LOG)
    nav.on_goal(NavGoal(5.5, "g2", place="room_b"))
    saver.take_up(6.0)
    assert nav.status.goal_id == "g2" and fleet.avoided == set()
