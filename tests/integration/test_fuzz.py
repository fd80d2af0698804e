"""Fuzz a running fleet: 10,000+ bad messages on every key it listens to, then the demo.

The whole sim profile runs in lockstep over a real router (as in test_fleet.py). The test
reads every key the services subscribe to (or serve) from their own start-up lines, then
puts seeded random and mutated payloads on each of them, spread evenly: random bytes,
truncated and bit-flipped valid messages, and (the larger part) msgpack maps that are
wheelnav-shaped but wrong (another type, an unknown tag, a bad schema version, a field
missing, unknown, of the wrong type, NaN, 1e300, lengths that disagree, broken arrays).
Each payload is checked in this process to be refused by the codec for that key's type
before it is sent, so no message changes the fleet's state (goals, initial poses, planner
updates, the clock, acks, commands...). Then every service's Diagnostics must show its
bad-message count on each key risen by exactly the number sent there, no service may have
died or been restarted, and the demo mission must then succeed.
"""

from __future__ import annotations

import random
import re
import threading
import time
from collections import Counter

import msgpack
import numpy as np
import pytest
import yaml
import zenoh

from shared import config as config_mod
from shared import messages as m
from shared.codec import DecodeError, decode, encode
from shared.topics import TOPICS, Keys
from tests.integration.test_fleet import DEMO, READY_S, Capture
from tests.shared.test_codec import samples
from wheelnav.launcher.fleet import services_for
from wheelnav.launcher.supervisor import Supervisor, wait_ready
from wheelnav.mission.report import Recorder, format_report
from wheelnav.mission.scenario import load_scenario

pytestmark = pytest.mark.e2e

SEED = 12
TOTAL = 10_400  # messages, spread evenly over the keys
SUBSCRIBES = re.compile(r"wheelnav\.(\w+): (subscribes|serves) (\S+)")
BAD_VALUES = [
    float("nan"),
    float("inf"),
    -float("inf"),
    1e300,
    -1e300,
    1e13,
    "text",
    b"\x00bytes",
    [],
    [1, "a"],
    {},
    {"x": 1},
    None,
    True,
    2**63,
    -(2**63),
    msgpack.ExtType(5, b"?"),
    msgpack.ExtType(1, b"\x92\xa3<f8\x91\x05" + b"\x00" * 7),  # 5 float64 in 7 bytes
    msgpack.ExtType(1, b"\xc1garbage"),
    msgpack.ExtType(1, msgpack.packb(["|O", [1]]) + b"\x00" * 8),  # object array
]


def _arr(values: np.ndarray) -> msgpack.ExtType:
    header = msgpack.packb([values.dtype.str, list(values.shape)])
    return msgpack.ExtType(1, header + np.ascontiguousarray(values).tobytes())


class Fuzzer:
    """Seeded payloads that the codec refuses for a given message type."""

    def __init__(self, seed: int) -> None:
        self.rng = random.Random(seed)
        self.valid = {type(s): s for s in samples()}
        self.wires = {
            cls: msgpack.unpackb(encode(msg), raw=False) for cls, msg in self.valid.items()
        }
        self.kinds: Counter[str] = Counter()

    def payload(self, cls: type) -> bytes:
        """One payload ``decode(payload, cls)`` refuses (drawn again until it does)."""
        for _ in range(1000):
            kind, data = self._draw(cls)
            try:
                decode(data, cls)
            except DecodeError:
                self.kinds[kind] += 1
                return data
        raise AssertionError(f"no invalid payload for {cls.__name__} in 1000 draws")

    def _draw(self, cls: type) -> tuple[str, bytes]:
        r = self.rng.random()
        valid = encode(self.valid[cls])
        if r < 0.10:
            return "random bytes", self.rng.randbytes(self.rng.randrange(0, 80))
        if r < 0.20:
            return "truncated", valid[: self.rng.randrange(0, len(valid))]
        if r < 0.32:
            buf = bytearray(valid)
            for _ in range(self.rng.randint(1, 4)):
                buf[self.rng.randrange(len(buf))] = self.rng.randrange(256)
            return "bit flips", bytes(buf)
        return self._structured(cls)

    def _structured(self, cls: type) -> tuple[str, bytes]:
        rng = self.rng
        obj = _deep_copy(self.wires[cls])
        how = rng.choice(
            [
                "not a map",
                "no t/v/d",
                "unknown tag",
                "another type",
                "bad version",
                "field missing",
                "unknown field",
                "bad value",
                "bad value",
                "bad value",
                "bad nested value",
                "fields disagree",
            ]
        )
        if how == "not a map":
            obj = rng.choice([None, 7, -1.5, "twist", b"\x01", [obj["t"], obj["v"], obj["d"]]])
        elif how == "no t/v/d":
            del obj[rng.choice(["t", "v", "d"])]
        elif how == "unknown tag":
            obj["t"] = rng.choice(["teleport", "", obj["t"].upper(), obj["t"] + "2"])
        elif how == "another type":
            other = rng.choice([c for c in self.wires if c is not cls])
            obj = _deep_copy(self.wires[other])
        elif how == "bad version":
            obj["v"] = rng.choice([0, -1, -(2**31), "1", 1.0, True, None, cls.VERSION + 1, 2**40])
        elif how == "field missing":
            if not obj["d"]:
                return self._structured(cls)
            del obj["d"][rng.choice(sorted(obj["d"]))]
        elif how == "unknown field":
            obj["d"][rng.choice(["extra", "x", "speed", "__class__"])] = rng.choice(BAD_VALUES)
        elif how in ("bad value", "bad nested value"):
            target = _pick_map(obj["d"], rng, nested=how == "bad nested value")
            if not target:
                return self._structured(cls)
            target[rng.choice(sorted(target))] = rng.choice(BAD_VALUES)
        else:
            obj = self._disagree(cls, obj)
        return how, msgpack.packb(obj)

    def _disagree(self, cls: type, obj: dict) -> dict:
        """Fields that pass one by one but not together (or numbers out of their range)."""
        d, rng = obj["d"], self.rng
        if cls is m.Path:
            n = rng.randint(2, 5)
            d["waypoints"] = _arr(np.zeros((n, 2)))
            d["v_ref"] = _arr(np.full(rng.choice([0, 1, n - 1, n + 1]), 0.5))
        elif cls is m.BuildingBodies:
            d["door_openings"] = _arr(np.zeros(len(d["doors"]) + rng.choice([-1, 1, 2])))
        elif cls is m.Ack:
            d["next_tick"] = d["tick"] - rng.randint(0, 3)
        elif cls is m.NavGoal:
            d.pop("goal", None)
            d["place"], d["cancel"] = "", False
        elif cls is m.Availability:
            d["name"] = ""
        elif cls is m.PointCloud:
            d["points"] = _arr(np.full((4, 3), rng.choice([1e30, -1e9]), np.float32))
        else:  # a number far outside any range: the 1e300 m/s
            numbers = [k for k, v in d.items() if isinstance(v, float | int)]
            if numbers:
                d[rng.choice(numbers)] = rng.choice([1e300, -1e300, 1e15, -(2**60)])
            else:
                obj["v"] = 0
        return obj


def _deep_copy(value):
    if isinstance(value, dict):
        return {k: _deep_copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_deep_copy(v) for v in value]
    return value


def _pick_map(d: dict, rng: random.Random, nested: bool) -> dict:
    """``d`` or (``nested``) a map inside it: a nested message, or one in a list."""
    if not nested:
        return d
    inner = [v for v in d.values() if isinstance(v, dict)]
    inner += [x for v in d.values() if isinstance(v, list) for x in v if isinstance(x, dict)]
    return rng.choice(inner) if inner else d


def decodes_as_msgpack(payload: bytes) -> bool:
    try:
        msgpack.unpackb(payload, raw=True, strict_map_key=False)
    except Exception:
        return False
    return True


def type_of_key(keys: Keys, key: str) -> type:
    """The message type of a key a service declared (from the topic table)."""
    expr = zenoh.KeyExpr(key)
    for t in TOPICS:
        if t.msg is not None and zenoh.KeyExpr(keys.key(t.name)).includes(expr):
            return t.msg
    raise AssertionError(f"{key}: no topic in shared/topics.py covers it")


def concrete(key: str) -> str:
    """A key to put on for a declared key expression (a wildcard chunk filled in)."""
    return key.replace("**", "fuzz").replace("*", "fuzz")


@pytest.fixture
def running_fleet(router, tmp_path):
    """The sim profile under the supervisor, in lockstep, as fast as possible."""
    bus, endpoint = router
    scenario = load_scenario(DEMO)
    cfg = scenario.config
    cfg.sim.start_after = [s.name for s in services_for("sim") if s.name != "sim"]
    cfg_path = tmp_path / "fleet.yaml"
    cfg_path.write_text(yaml.safe_dump(config_mod.to_dict(cfg)))
    out = Capture()
    specs = services_for("sim")
    sup = Supervisor(specs, endpoint, cfg.launcher, str(cfg_path), out=out)
    sup.start()
    try:
        missing = wait_ready(bus, Keys(cfg.robot.name), [s.name for s in specs], READY_S)
        assert not missing, out.text()[-3000:]
        yield bus, sup, Keys(cfg.robot.name), scenario, out, [s.name for s in specs]
    finally:
        sup.stop()


def test_fleet_survives_10k_bad_messages_then_drives_the_demo(running_fleet) -> None:
    bus, sup, keys, scenario, out, names = running_fleet
    started = time.monotonic()
    goal_id = "fuzz-demo"
    recorder = Recorder(goal_id)
    latest: dict[str, m.Diagnostics] = {}
    lock = threading.Condition()

    def on_diag(msg: m.Diagnostics) -> None:
        with lock:
            latest[msg.service] = msg
            recorder.on_diagnostics(msg)
            lock.notify_all()

    def on_status(msg: m.NavStatus) -> None:
        with lock:
            recorder.on_status(msg)
            lock.notify_all()

    bus.subscribe(keys.key("diagnostics"), m.Diagnostics, on_diag)
    bus.subscribe(keys.nav_status, m.NavStatus, on_status)
    bus.subscribe(keys.sim_status, m.SimStatus, recorder.on_sim_status)
    bus.subscribe(keys.ground_truth, m.Odometry, lambda o: recorder.on_truth(o.pose.x, o.pose.y))
    pids = {name: sup.pid(name) for name in names}

    # every key each service listens to, as it declared it (a service that declared a key
    # twice counts each message there twice)
    declared: dict[str, Counter[str]] = {}
    for service, _what, key in SUBSCRIBES.findall(out.text()):
        declared.setdefault(key, Counter())[service] += 1
    queried = {k for _s, what, k in SUBSCRIBES.findall(out.text()) if what == "serves"}
    assert len(declared) >= 15, declared
    assert {keys.nav_goal, keys.initial_pose, keys.planner_updates, keys.clock} <= set(declared)
    listeners = {s for services in declared.values() for s in services}
    assert listeners == set(names), (listeners, names)

    # baseline: one Diagnostics per service after the last declaration
    with lock:
        assert lock.wait_for(lambda: set(latest) >= set(names), timeout=15), sorted(latest)
        base = {s: {k.key: k.bad_messages for k in d.keys} for s, d in latest.items()}

    fuzz = Fuzzer(SEED)
    per_key = -(-TOTAL // len(declared))
    payloads = {
        key: [fuzz.payload(type_of_key(keys, key)) for _ in range(per_key)]
        for key in sorted(declared)
    }
    sent = sum(len(p) for p in payloads.values())
    as_msgpack = sum(decodes_as_msgpack(p) for ps in payloads.values() for p in ps)
    assert sent >= 10_000 and as_msgpack >= sent / 2, (sent, as_msgpack, fuzz.kinds)

    # interleave the keys, as garbage from many sources would arrive
    queue = [(key, p) for key, ps in payloads.items() for p in ps]
    random.Random(SEED).shuffle(queue)
    fuzz_start = time.monotonic()
    for key, payload in queue:
        if key in queried:
            bus.session.get(concrete(key), lambda _reply: None, payload=payload, timeout=10.0)
        else:
            bus.session.put(
                concrete(key), payload, congestion_control=zenoh.CongestionControl.BLOCK
            )
    put_s = time.monotonic() - fuzz_start

    def risen() -> dict[tuple[str, str], tuple[int, int]]:
        """(service, key) -> (bad messages counted since the baseline, sent)."""
        got = {}
        for key, services in declared.items():
            for s in services:
                now = {k.key: k.bad_messages for k in latest[s].keys}.get(key, 0)
                got[(s, key)] = (now - base[s].get(key, 0), services[s] * len(payloads[key]))
        return got

    with lock:
        lock.wait_for(lambda: all(a >= b for a, b in risen().values()), timeout=60)
        counted = risen()
    counted_s = time.monotonic() - fuzz_start
    wrong = {sk: v for sk, v in counted.items() if v[0] != v[1]}
    assert not wrong, f"bad-message counts (risen, sent) differ: {wrong}\n{out.text()[-3000:]}"
    for name in names:
        assert sup.pid(name) == pids[name], f"{name} died\n{out.text()[-3000:]}"
        assert sup.restarts(name) == 0 and latest[name].restarts == 0, name

    # the fleet is still whole: it drives the demo mission
    bus.publish(keys.nav_goal, m.NavGoal(0.0, goal_id, scenario.goal, scenario.place))
    with lock:
        lock.wait_for(lambda: recorder.finished, timeout=180)
    report = recorder.report("demo after fuzzing", time.monotonic() - fuzz_start)
    text = out.text()
    assert report["success"], (format_report(report), text[-3000:])
    assert report["collisions"] == 0
    assert "Traceback" not in text and "exited with code" not in text
    for name in names:
        assert sup.pid(name) == pids[name], f"{name} died during the mission"
    shown = report["diagnostics"]
    bad_sent = {s: 0 for s in names}
    for key, services in declared.items():
        for s in services:
            bad_sent[s] += services[s] * len(payloads[key])
    for s in names:
        assert shown[s]["bad_messages"] - sum(base[s].values()) == bad_sent[s], (s, shown[s])
        assert shown[s]["restarts"] == 0
    print(
        f"\nfuzz: {sent} messages on {len(declared)} keys ({len(queried)} queried), "
        f"{as_msgpack} decode as msgpack; kinds {dict(fuzz.kinds)}\n"
        f"sent in {put_s:.1f} s, all counted after {counted_s:.1f} s; "
        f"bad messages counted per service: {bad_sent}\n"
        + format_report(report)
        + f"\nwall time of the test body: {time.monotonic() - started:.1f} s"
    )
