"""A seeded slice of the randomized building campaign, as `wheelnav campaign` runs it.

The full campaign (docs/campaign.md) takes about half an hour per 50 missions and is run
by hand; this slice runs a few of its missions on the real fleet (lockstep, Zenoh on
loopback, pybullet) so a change that breaks generated buildings shows in `make test`.
It also shows the campaign resumes: a second run finds every row stored, and holds the
clearance limits of issue 13 (5 cm away from doors, centred in openings).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest

from wheelnav.campaign.runner import CampaignSpec, run

SLICE = ("b0.m00_same_floor", "b0.m02_door_stuck_alt", "b1.m03_door_stuck_no_way")


@pytest.mark.parametrize(
    "only",
    [
        pytest.param(SLICE[:1], id="one"),  # make test: one mission of a generated building
        pytest.param(SLICE, id="three", marks=pytest.mark.long),
    ],
)
def test_a_slice_of_the_campaign_runs_as_expected_and_resumes(
    tmp_path: Path, only: tuple[str, ...]
) -> None:
    spec = CampaignSpec(out=tmp_path, buildings=2, seed=0, missions=8, only=only)
    err, out = io.StringIO(), io.StringIO()
    result = run(spec, err=err, out=out)
    rows = {r["id"]: r for r in result["rows"]}
    assert set(rows) == set(only), err.getvalue()
    for mid, row in rows.items():
        assert row["as_expected"], f"{mid}: {row['outcome']} ({row['reason']})"
        assert row["collisions"] == 0, mid
        assert row["clearance_ok"], f"{mid}: {row['min_clearance_away_m']} {row['tight_doors']}"
        report = json.loads(Path(row["report"]).read_text())  # the whole report is kept
        assert report["scenario"].endswith(Path(row["scenario"]).stem), mid
        assert report["collisions"] == row["collisions"], mid
        assert report["phases"] and report["checkpoints"] and report["trace"], mid
    assert "geometry drawn" in out.getvalue() and "replay" not in out.getvalue()
    again = io.StringIO()
    second = run(spec, err=again, out=io.StringIO())
    assert again.getvalue().count(": stored (") == len(only)
    assert [r["outcome"] for r in second["rows"]] == [r["outcome"] for r in result["rows"]]
