"""The in-process fleet's exchange: buses hand each other checked objects instead of
bytes. Each subscriber gets what decoding the bytes would have given it, its own copy,
in publishing order; key expressions match as Zenoh matches them; a bad message is
refused in the publisher; bytes put on the session still arrive. Real Zenoh sessions on
loopback (a session routes within itself), no router."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from shared import messages as m
from shared.codec import EncodeError, checked, clone, decode, encode, to_plain
from shared.transport import Bus, Dispatcher, LocalExchange, open_local_session
from tests.conftest import eventually
from tests.shared.test_codec import samples


class Fleet:
    """Buses on one session, one dispatcher and one exchange, as the in-process fleet's."""

    def __init__(self, names: tuple[str, ...] = ("pub", "a", "b")) -> None:
        self.session = open_local_session()
        self.dispatcher = Dispatcher("test-deliveries")
        self.exchange = LocalExchange()
        self.buses = {
            n: Bus(
                self.session,
                n,
                owns_session=False,
                dispatcher=self.dispatcher,
                exchange=self.exchange,
            )
            for n in names
        }

    def __getitem__(self, name: str) -> Bus:
        return self.buses[name]

    def close(self) -> None:
        for bus in self.buses.values():
            bus.close()
        self.dispatcher.close()
        self.session.close()


@pytest.fixture
def fleet():
    f = Fleet()
    yield f
    f.close()


@pytest.mark.parametrize("msg", samples(), ids=lambda msg: msg.TAG)
def test_a_checked_clone_is_what_decoding_the_bytes_gives(msg: m.Msg) -> None:
    want = decode(encode(msg))
    got = clone(checked(msg))
    assert type(got) is type(want) and to_plain(got) == to_plain(want)
    assert repr(got) == repr(want)  # types too: floats, plain text, arrays' dtypes


def test_text_and_numbers_of_subclasses_arrive_as_the_wire_gives_them() -> None:
    status = m.NavStatus(1, "g", "running", "navigate", m.Phase.PASS, "", 0.5)
    got = checked(status)
    assert type(got.phase) is str and got.phase == "pass"
    assert type(got.stamp) is float and got.stamp == 1.0
    assert repr(got) == repr(decode(encode(status)))


def test_checked_refuses_what_encode_refuses_with_the_same_line() -> None:
    bad = [
        m.Twist(1.0, float("nan"), 0.0),
        m.Twist(1.0, 1e300, 0.0),
        m.Path(1.0, "p", "1", np.zeros((3, 2)), np.zeros(1)),
        m.PointCloud(1.0, "lidar", np.zeros((4, 3), dtype=np.float64)),
        m.Clock(1.0, -1, 0.02),
        # nested messages are checked as objects: a bad one, or one of a list, is named
        # as encode names it
        m.Odometry(1.0, m.Pose2D(float("inf"), 0.0, 0.0, "1"), 0.0, 0.0),
        m.Odometry(1.0, {"x": 1.0}, 0.0, 0.0),
        m.TreeSnapshot(
            1.0,
            "g",
            "route",
            [
                m.TreeNode(0, -1, "root", "Sequence", "RUNNING"),
                m.TreeNode(1, 0, "x", "", "", float("nan")),
            ],
        ),
        m.TreeSnapshot(1.0, "g", "route", [m.TreeNode(0, -1, "a", "b", "c"), "not a node"]),
        m.TreeSnapshot(1.0, "g", "route", [m.TreeNode(0, -1, "a", "b", "c")] * 2),  # validate
    ]
    for msg in bad:
        with pytest.raises(EncodeError) as by_encode:
            encode(msg)
        with pytest.raises(EncodeError) as by_checked:
            checked(msg)
        assert str(by_checked.value) == str(by_encode.value)


def test_each_subscriber_gets_its_own_copy_in_publishing_order(fleet) -> None:
    got: dict[str, list] = {"a": [], "b": []}
    fleet["a"].subscribe("t/scan", m.PointCloud, got["a"].append)
    fleet["b"].subscribe("t/**", None, got["b"].append)
    pts = np.arange(12, dtype=np.float32).reshape(4, 3)
    fleet["pub"].publish("t/scan", m.PointCloud(1.0, "lidar", pts))
    fleet["pub"].publish("t/clock", m.Clock(1.0, 50, 0.02))
    pts[0, 0] = -7.0  # the publisher's later writes reach nobody
    assert eventually(lambda: len(got["a"]) == 1 and len(got["b"]) == 2)
    a, b = got["a"][0], got["b"][0]
    assert [type(x) for x in got["b"]] == [m.PointCloud, m.Clock]
    assert a is not b and a.points is not b.points
    a.points[0, 0] = 99.0  # consumers may work in place, as on decoded arrays
    assert b.points[0, 0] == 0.0 and a.points[1, 0] == 3.0
    assert fleet["a"].counters() == {"t/scan": (1, 0)}
    assert fleet["b"].counters() == {"t/**": (2, 0)}


def test_key_expressions_match_as_zenohs_and_a_wrong_type_is_counted(fleet) -> None:
    got: list[tuple[str, int]] = []
    fleet["a"].subscribe("w/*/state", m.Clock, lambda c: got.append(("one", c.tick)))
    fleet["b"].subscribe("w/**", m.Clock, lambda c: got.append(("any", c.tick)))
    fleet["pub"].publish("w/d1/state", m.Clock(0.0, 1, 0.02))
    fleet["pub"].publish("w/d1/x/state", m.Clock(0.0, 2, 0.02))
    fleet["pub"].publish("v/d1/state", m.Clock(0.0, 3, 0.02))
    fleet["pub"].publish("w/d2/state", m.Twist(0.0, 0.1, 0.0))  # not a Clock
    assert eventually(lambda: fleet["a"].counters().get("w/*/state", (0, 0))[1] == 1)
    assert eventually(lambda: fleet["b"].counters().get("w/**", (0, 0))[1] == 1)
    assert sorted(got) == [("any", 1), ("any", 2), ("one", 1)]
    assert fleet["a"].counters() == {"w/*/state": (2, 1)}


def test_a_bad_message_is_refused_in_the_publisher_and_reaches_nobody(fleet) -> None:
    got: list = []
    fleet["a"].subscribe("t/cmd", m.Twist, got.append)
    with pytest.raises(EncodeError, match="v"):
        fleet["pub"].publish("t/cmd", m.Twist(0.0, float("nan"), 0.0))
    fleet["pub"].publish("t/cmd", m.Twist(0.0, 0.2, 0.0))
    assert eventually(lambda: len(got) == 1)
    assert got[0].v == 0.2 and fleet["a"].counters() == {"t/cmd": (1, 0)}


def test_bytes_put_on_the_session_still_arrive_and_raw_subscribers_get_bytes(fleet) -> None:
    typed: list = []
    raw: list[tuple[str, bytes]] = []
    fleet["a"].subscribe("t/clock", m.Clock, typed.append)
    fleet["b"].subscribe_raw("t/**", lambda k, p: raw.append((k, p)))
    time.sleep(0.2)
    fleet.session.put("t/clock", encode(m.Clock(0.0, 7, 0.02)))  # from outside the exchange
    fleet.session.put("t/clock", b"\x92garbage")
    fleet["pub"].publish("t/clock", m.Clock(0.0, 8, 0.02))
    assert eventually(lambda: len(typed) == 2 and len(raw) == 3)
    assert [c.tick for c in typed] == [7, 8]
    assert fleet["a"].counters() == {"t/clock": (3, 1)}
    assert decode(raw[-1][1]).tick == 8 and raw[-1][0] == "t/clock"


def test_latest_skips_only_superseded_ticks_and_a_closed_bus_takes_nothing(fleet) -> None:
    got: list[int] = []
    gate = threading.Event()

    def slow(c: m.Clock) -> None:
        gate.wait(10.0)
        got.append(c.tick)

    fleet["a"].subscribe("t/tick", m.Clock, slow, latest=True)
    for tick in range(5):
        fleet["pub"].publish("t/tick", m.Clock(0.0, tick, 0.02))
    gate.set()
    assert eventually(lambda: got and got[-1] == 4)
    assert got in ([0, 4], [4])  # the one being handled, then the newest
    fleet["a"].close()
    fleet["pub"].publish("t/tick", m.Clock(0.0, 9, 0.02))
    time.sleep(0.2)
    assert 9 not in got
