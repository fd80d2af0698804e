"""Manoeuvres in tight rooms: the search finds turns and straight drives where turn-drive-
turn does not fit, and every pose along them keeps the margin."""

from __future__ import annotations

import heapq
import math

import numpy as np

from services.controller.manoeuvre import (
    Budget,
    ManoeuvreBody,
    ManoeuvreCosts,
    Room,
    plan_manoeuvre,
    simple_manoeuvre,
)
from shared.config import RobotConfig
from shared.geometry import footprint_gap, wrap_angle

RES = 0.05
FP = RobotConfig().footprint
BODY = ManoeuvreBody(FP.front, FP.rear, FP.width, 0.05)


def series_room() -> tuple[np.ndarray, tuple[float, float]]:
    """Campaign b4.m07's room between two doors in series, 2.08 x 2.0 m inside (x 0-2.08,
    y 0-2.0) with 0.2 m walls, a 0.9 m door in the left wall (y 0.88-1.78) and one in the
    right wall (y 0.08-0.98), and 1 m of free space beyond each door."""
    x0, y0 = -1.4, -0.4
    w, h = round(4.9 / RES), round(2.8 / RES)
    cx = x0 + (np.arange(w) + 0.5) * RES
    cy = y0 + (np.arange(h) + 0.5) * RES
    gx, gy = np.meshgrid(cx, cy)
    free = (gx > 0) & (gx < 2.08) & (gy > 0) & (gy < 2.0)
    free |= (gx > -1.2) & (gx <= 0) & (gy > 0.88) & (gy < 1.78)  # the left door and beyond
    free |= (gx >= 2.08) & (gx < 3.3) & (gy > 0.08) & (gy < 0.98)  # the right door and beyond
    return ~free, (x0, y0)


def clearance(occ: np.ndarray, origin, pose) -> float:
    """The footprint's distance to the nearest occupied cell (its nearest point)."""
    r, c = np.nonzero(occ)
    x = origin[0] + (c + 0.5) * RES
    y = origin[1] + (r + 0.5) * RES
    th = pose[2]
    dx, dy = x - pose[0], y - pose[1]
    body = np.column_stack(
        (dx * math.cos(th) + dy * math.sin(th), -dx * math.sin(th) + dy * math.cos(th))
    )
    return float(footprint_gap(body, FP.front, FP.rear, FP.width).min()) - RES * math.sqrt(0.5)


def along(poses):
    """Every pose the chair passes through: turns in 1-degree steps, drives in 1 cm steps."""
    for a, b in zip(poses[:-1], poses[1:], strict=True):
        if math.hypot(b[0] - a[0], b[1] - a[1]) < 1e-9:  # a turn on the spot
            d = wrap_angle(b[2] - a[2])
            for i in range(int(abs(math.degrees(d))) + 1):
                yield (a[0], a[1], a[2] + math.copysign(math.radians(i), d))
        else:  # a straight drive along a's heading, forwards or back
            heading = math.atan2(b[1] - a[1], b[0] - a[0])
            assert abs(math.sin(wrap_angle(heading - a[2]))) < 0.02, (a, b)
            assert abs(wrap_angle(b[2] - a[2])) < 1e-9, (a, b)
            n = int(math.hypot(b[0] - a[0], b[1] - a[1]) / 0.01) + 1
            for i in range(n + 1):
                yield (a[0] + (b[0] - a[0]) * i / n, a[1] + (b[1] - a[1]) * i / n, a[2])


def test_between_two_doors_in_series_it_turns_where_the_room_allows() -> None:
    occ, origin = series_room()
    room = Room(occ, RES, origin, BODY)
    start, goal = (1.01, 1.33, 0.0), (1.19, 0.53, 0.0)  # door 1's exit, door 2's approach
    assert simple_manoeuvre(room, start, goal) is None  # no room to turn at either pose
    poses = plan_manoeuvre(room, start, goal)
    assert poses is not None
    assert math.hypot(poses[-1][0] - goal[0], poses[-1][1] - goal[1]) < RES
    assert abs(wrap_angle(poses[-1][2] - goal[2])) < 1e-6
    worst = min(clearance(occ, origin, p) for p in along([start, *poses]))
    assert worst >= 0.05 - 0.01  # the margin, less what 5-degree heading steps can miss


def test_in_open_space_it_is_turn_drive_turn() -> None:
    occ = np.zeros((100, 100), dtype=bool)
    room = Room(occ, RES, (-2.5, -2.5), BODY)
    poses = plan_manoeuvre(room, (0.0, 0.0, 0.0), (0.8, 0.6, math.pi / 2))
    assert poses is not None and len(poses) == 3
    assert poses[0][:2] == (0.0, 0.0) and poses[1][:2] == (0.8, 0.6)


def test_a_goal_in_a_wall_or_out_of_reach_gives_none() -> None:
    occ, origin = series_room()
    room = Room(occ, RES, origin, BODY)
    assert plan_manoeuvre(room, (1.01, 1.33, 0.0), (1.0, -0.2, 0.0)) is None  # in the wall
    boxed = np.ones((60, 60), dtype=bool)
    boxed[10:50, 10:50] = False
    boxed[:, 29:31] = True  # two closed halves
    small = Room(boxed, RES, (0.0, 0.0), ManoeuvreBody(0.3, 0.1, 0.3, 0.02))
    assert plan_manoeuvre(small, (0.9, 1.5, 0.0), (2.1, 1.5, 0.0)) is None


def test_a_goal_too_near_a_wall_ends_the_search_within_a_docking_tolerance() -> None:
    """Campaign b2.m00: the second door's approach pose stood 5 cm from the tip of an open
    leaf, inside the margin, and no manoeuvre was planned at all."""
    occ, origin = series_room()
    room = Room(occ, RES, origin, BODY)
    goal = (1.19, 0.39, 0.0)  # the footprint 0.065 m above the room's bottom wall
    assert not room.fits(*goal[:2], 0)
    poses = plan_manoeuvre(room, (1.01, 1.33, 0.0), goal)
    assert poses is not None
    end = poses[-1]
    assert 0 < math.hypot(end[0] - goal[0], end[1] - goal[1]) <= 0.15
    assert abs(wrap_angle(end[2] - goal[2])) <= math.radians(5) + 1e-9
    assert room.fits(end[0], end[1], round(end[2] / (2 * math.pi) * 72) % 72)


def offset_series_room() -> tuple[np.ndarray, tuple[float, float]]:
    """Campaign b0.m08's room between two doors in series, relative to the second door's
    approach pose (the origin, facing -y): 2.1 x 1.7 m inside, the first door (1.15 m,
    closed behind the chair) in the top wall, 0.33 m to the right of the second (0.90 m,
    closed ahead) in the bottom wall; 0.2 m walls."""
    x0, y0 = -1.5, -1.6
    w, h = round(3.6 / RES), round(3.2 / RES)
    cx = x0 + (np.arange(w) + 0.5) * RES
    cy = y0 + (np.arange(h) + 0.5) * RES
    gx, gy = np.meshgrid(cx, cy)
    free = (gx > -0.75) & (gx < 1.35) & (gy > -0.85) & (gy < 0.85)
    free |= (gx > -0.45) & (gx < 0.45) & (gy > -0.975) & (gy <= -0.85)  # door 2, leaf at -1.0
    free |= (gx > -0.25) & (gx < 0.9) & (gy >= 0.85) & (gy < 0.875)  # door 1, leaf at 0.9
    return ~free, (x0, y0)


def test_a_goal_just_inside_the_margin_ahead_is_reached_on_its_line() -> None:
    """Campaign b0.m08 at 65eb10a: the approach pose of the second door of a series pair
    lay 1-2 cm inside the grown footprint's margin at the door's jamb corners; the search
    (at the docker's first margin, 0.08 m) took any pose within 0.15 m, ended 0.14 m
    beside the door's line, and docking, with no room for a sidestep, ended 0.16 m off
    after three attempts: the mission failed. Where the goal does not fit, a pose on its
    line a little short of it does."""
    occ, origin = offset_series_room()
    room = Room(occ, RES, origin, ManoeuvreBody(FP.front, FP.rear, FP.width, 0.08))
    goal = (0.0, 0.0, -math.pi / 2)
    assert not room.fits(0.0, 0.0, 54)  # 54 of 72 heading steps: -90 deg
    poses = plan_manoeuvre(room, (0.33, 0.18, math.radians(6.6)), goal)
    assert poses is not None
    end = poses[-1]
    assert abs(end[0] - goal[0]) < RES, poses  # on the door's line (x, across -y)
    assert abs(end[1] - goal[1]) <= 0.15 and abs(wrap_angle(end[2] - goal[2])) < 1e-6


def test_a_start_inside_the_margin_is_left_by_a_straight_drive() -> None:
    """Camp21 b2.m00: through a door into a large room, the chair turned towards its goal
    until the safety checks held it, its rear corner 7 cm from the wall behind on its left
    (inside the search's grown margin). Every move from there was refused, so no
    manoeuvre was found three times and the mission failed, with the room wide open
    ahead. Straight drives out of a start that does not fit are allowed, a few steps,
    until the poses fit again; then the search goes on as usual."""
    occ = np.zeros((80, 80), dtype=bool)
    occ[:, :10] = True  # a wall: x < -1.5 (the room is x in [-1.5, 2.5], y in [-2, 2])
    origin = (-2.0, -2.0)
    room = Room(occ, RES, origin, BODY)
    th = math.radians(62)
    # the rear-left corner (0.35 back, 0.325 aside) 4 cm from the wall's face
    corner_x = -0.35 * math.cos(th) - 0.325 * math.sin(th)
    start = (-1.5 + 0.04 - corner_x, 0.0, th)
    assert not room.fits(*start[:2], round(th / (2 * math.pi / 72)))
    poses = plan_manoeuvre(room, start, (start[0], start[1], math.radians(3)))
    assert poses is not None
    first = next(p for p in poses if math.hypot(p[0] - start[0], p[1] - start[1]) > 1e-9)
    assert abs(wrap_angle(first[2] - th)) < math.radians(5)  # out straight, not turned
    assert abs(wrap_angle(poses[-1][2] - math.radians(3))) < 1e-6


def reference_free(points: np.ndarray, slack: float, shape, body: ManoeuvreBody, k: int):
    """Free cells at heading step ``k``, cell by cell: no point within the footprint at
    the cell's centre grown by the margin, half a cell diagonal and ``slack``."""
    from services.controller.manoeuvre import HEADINGS

    grow = body.margin_m + RES * math.sqrt(0.5) + slack
    th = 2 * math.pi * k / HEADINGS
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    qx, qy = (cols.ravel() + 0.5) * RES, (rows.ravel() + 0.5) * RES
    dx, dy = points[:, 0][None, :] - qx[:, None], points[:, 1][None, :] - qy[:, None]
    bx, by = math.cos(th) * dx + math.sin(th) * dy, -math.sin(th) * dx + math.cos(th) * dy
    covered = (bx >= -body.rear - grow) & (bx <= body.front + grow)
    covered &= np.abs(by) <= body.width / 2 + grow
    free = ~covered.any(axis=1).reshape(shape)
    free[0, :] = free[-1, :] = False
    free[:, 0] = free[:, -1] = False
    return free


def test_the_room_is_stamped_from_what_is_occupied_as_checked_cell_by_cell() -> None:
    """The room's free cells per heading, stamped point by point, are those where the
    grown footprint at the cell's centre covers no occupied cell's centre (grown by half
    a cell more) or no point (grown by half a merged cell more), as a reference that
    checks every cell against every point finds them."""
    from services.controller.manoeuvre import HEADINGS, POINT_CELL_M

    rng = np.random.default_rng(7)
    occ = rng.random((30, 40)) < 0.03
    occ[12, :] = True
    r, c = np.nonzero(occ)
    centres = np.column_stack(((c + 0.5) * RES, (r + 0.5) * RES))
    points = rng.uniform((0.0, 0.0), (2.0, 1.5), (60, 2))
    merged = (np.unique(np.floor(points / POINT_CELL_M), axis=0) + 0.5) * POINT_CELL_M
    for margin in (0.0, 0.05):
        body = ManoeuvreBody(FP.front, FP.rear, FP.width, margin)
        room = Room(occ, RES, (0.0, 0.0), body)
        scanned = Room.from_points(points, RES, (0.0, 0.0), occ.shape, body)
        for k in range(0, HEADINGS, 7):
            ref = reference_free(centres, RES * math.sqrt(0.5), occ.shape, body, k)
            assert np.array_equal(room.free[k], ref), (margin, k)
            ref = reference_free(merged, POINT_CELL_M * math.sqrt(0.5), occ.shape, body, k)
            assert np.array_equal(scanned.free[k], ref), (margin, k)


def reference_plan(room: Room, start, goal, costs: ManoeuvreCosts):
    """The search as it was written in Python before it was compiled, on the same room:
    the compiled one must give the very same poses (or None) and use as many expansions."""
    from services.controller import manoeuvre as m

    def fits(x, y, k):
        r, c = math.floor((y - room.oy) / room.res), math.floor((x - room.ox) / room.res)
        h, w = room.shape
        return 0 <= r < h and 0 <= c < w and bool(room.free[k % m.HEADINGS, r, c])

    def turn_fits(x, y, k0, k1):
        d = (k1 - k0 + m.HEADINGS // 2) % m.HEADINGS - m.HEADINGS // 2
        if not fits(x, y, k0):
            return False
        step = 1 if d >= 0 else -1
        return all(fits(x, y, (k0 + i * step) % m.HEADINGS) for i in range(abs(d) + 1))

    def simple(start, goal, turns):
        x0, y0, t0 = start
        x1, y1, t1 = goal
        k0, kg = m.heading_step(t0), m.heading_step(t1)
        if math.hypot(x1 - x0, y1 - y0) < room.res:
            return [(x0, y0, t1)] if turn_fits(x0, y0, k0, kg) else None
        face = math.atan2(y1 - y0, x1 - x0)
        for drive in (face, wrap_angle(face + math.pi)):
            k = m.heading_step(drive)
            if k not in turns:
                turns[k] = turn_fits(x1, y1, k, kg)
            if turns[k] and room.drive_fits(x0, y0, x1, y1, k) and turn_fits(x0, y0, k0, k):
                return [(x0, y0, drive), (x1, y1, drive), (x1, y1, t1)]
        return None

    k0, kg = m.heading_step(start[2]), m.heading_step(goal[2])
    ok = fits(goal[0], goal[1], kg)
    if not ok:
        on_line = m._on_line(room, goal, kg, costs.goal_slack_m)
        if on_line is not None:
            goal, ok = on_line, True
    reach = room.res if ok else costs.goal_slack_m
    steps_off = 0 if ok else 1
    direct = simple(start, goal, {})
    if direct is not None:
        return direct, 0
    step, turn_cost = room.res, costs.turn_m_per_rad * 2 * math.pi / m.HEADINGS

    def heuristic(x, y, k):
        steps = abs((kg - k + m.HEADINGS // 2) % m.HEADINGS - m.HEADINGS // 2)
        return math.hypot(goal[0] - x, goal[1] - y) + turn_cost * max(0, steps - steps_off)

    def chain(key):
        out = []
        while key is not None:
            out.append(node_of[key])
            key = parent[key]
        return m._poses(out[::-1])

    key0 = (*room.cell(start[0], start[1]), k0, m.TURN)
    best, parent, node_of = {key0: 0.0}, {key0: None}, {key0: (start[0], start[1], k0, m.TURN)}
    escape = {key0: 0 if fits(start[0], start[1], k0) else 1}
    queue, expanded, turns = [(heuristic(start[0], start[1], k0), 0.0, key0)], 0, {}
    while queue and expanded < costs.max_expansions:
        _, g, key = heapq.heappop(queue)
        if g > best.get(key, math.inf):
            continue
        expanded += 1
        x, y, k, mode = node_of[key]
        if (
            math.hypot(goal[0] - x, goal[1] - y) < reach
            and abs((k - kg + m.HEADINGS // 2) % m.HEADINGS - m.HEADINGS // 2) <= steps_off
        ):
            return chain(key), expanded
        tail = simple((x, y, m.step_heading(k)), goal, turns)
        if tail is not None:
            return chain(key) + tail, expanded
        th = m.step_heading(k)
        moves = [
            (x, y, (k + 1) % m.HEADINGS, m.TURN, turn_cost),
            (x, y, (k - 1) % m.HEADINGS, m.TURN, turn_cost),
        ]
        for sign, move_mode, factor in (
            (1.0, m.FORWARD, 1.0),
            (-1.0, m.BACK, costs.reverse_factor),
        ):
            moves.append(
                (
                    x + sign * step * math.cos(th),
                    y + sign * step * math.sin(th),
                    k,
                    move_mode,
                    step * factor,
                )
            )
        out = escape.get(key, 0)
        for nx, ny, nk, nmode, cost in moves:
            ok = fits(nx, ny, nk)
            if not ok and (not out or nmode == m.TURN or out >= m.ESCAPE_STEPS):
                continue
            ng = g + cost + (costs.switch_m if nmode != mode and key != key0 else 0.0)
            nkey = (*room.cell(nx, ny), nk, nmode)
            if ng < best.get(nkey, math.inf):
                best[nkey], parent[nkey], node_of[nkey] = ng, key, (nx, ny, nk, nmode)
                escape[nkey] = 0 if ok else out + 1
                heapq.heappush(queue, (ng + heuristic(nx, ny, nk), ng, nkey))
    return None, expanded


def test_the_compiled_search_gives_the_poses_the_python_search_gave() -> None:
    """The search runs compiled (in lockstep the controller's tick waits for it); on
    random cluttered rooms, starts that fit or not and goals that fit or not, it returns
    exactly the poses the Python loop it replaced returned, after as many expansions."""
    rng = np.random.default_rng(11)
    costs = ManoeuvreCosts(max_expansions=4000)
    searched = found = 0
    for case in range(40):
        occ = np.zeros((60, 60), dtype=bool)
        occ[:3, :] = occ[-3:, :] = occ[:, :3] = occ[:, -3:] = True
        for _ in range(rng.integers(1, 5)):
            r, c = rng.integers(3, 55, 2)
            occ[r : r + rng.integers(2, 12), c : c + rng.integers(2, 12)] = True
        margin = float(rng.choice([0.0, 0.025, 0.05]))
        room = Room(occ, RES, (0.0, 0.0), ManoeuvreBody(FP.front, FP.rear, FP.width, margin))
        start = (*rng.uniform(0.6, 2.4, 2), float(rng.uniform(-math.pi, math.pi)))
        goal = (*rng.uniform(0.6, 2.4, 2), float(rng.uniform(-math.pi, math.pi)))
        budget = Budget(costs.max_expansions)
        got = plan_manoeuvre(room, start, goal, costs, budget)
        want, expanded = reference_plan(room, start, goal, costs)
        assert got == want, case
        assert costs.max_expansions - budget.left == expanded, case
        searched += expanded > 0
        found += expanded > 0 and want is not None
    assert searched >= 20 and found >= 5, (searched, found)
