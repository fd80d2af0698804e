"""The LiDAR's consecutive-open count, as the status text shows it."""

from __future__ import annotations

from behaviours.fleet import OpenInScans


def test_the_count_never_reads_more_than_it_needs() -> None:
    # issue 13 failure mode 8: the status read "LiDAR open in 14/3 scans"
    seen = OpenInScans(3)
    for stamp in range(14):
        seen.update(float(stamp), "open")
    assert str(seen) == "LiDAR open in 3 of 3 scans"
    seen.update(20.0, "closed")
    assert str(seen) == "LiDAR open in 0 of 3 scans"
