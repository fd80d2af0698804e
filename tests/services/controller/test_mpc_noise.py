"""The MPC's noise drawn a cycle ahead: the same numbers, in the same order, as drawing
each block at its cycle."""

from __future__ import annotations

import threading

import numpy as np

from services.controller.mpc_noise import THREAD_NAME, NoiseStream


def test_blocks_are_the_generators_draws_in_order_whatever_the_caller_does_to_them() -> None:
    shape = (50, 7, 2)
    direct = np.random.default_rng(4)
    a, b = NoiseStream(4, shape), NoiseStream(9, shape)  # two streams share the helper
    other = np.random.default_rng(9)
    for i in range(6):
        want = direct.standard_normal(shape, dtype=np.float32)
        got = a.take()
        if i % 2:  # the MPC starts the next draw once its kernel is done (twice: no-op)
            a.ahead()
            a.ahead()
        assert got.dtype == np.float32 and got.shape == shape
        assert np.array_equal(got, want)
        got[:3] = 0.0  # the MPC zeroes its exact samples in place
        assert np.array_equal(b.take(), other.standard_normal(shape, dtype=np.float32))
    assert THREAD_NAME in {t.name for t in threading.enumerate()}
