"""The simulator's status message encodes from a real simulation in and away from doorways."""

from __future__ import annotations

from services.sim.node import status_message
from shared.codec import decode, encode
from shared.messages import SimStatus
from tests.sim.test_simulation import make


def test_status_with_the_chair_in_a_doorway_encodes() -> None:
    # numpy scalars from the footprint once reached the codec and the sim restarted
    for sim in (make(x=5.9, y=2.6), make(x=6.2 - 0.76 + 0.1, y=2.7), make(x=2.0, y=2.7)):
        sim.step()
        back = decode(encode(status_message(sim, 1.0)), SimStatus)
        assert [d.entered for d in back.doors] == [d.entered for d in sim.door_clearance.values()]
    assert back.doors == [] and back.away_nearest == "wall"
