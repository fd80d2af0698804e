"""Normals drawn a block ahead: the same numbers, in the same order, as drawing each
take at its moment, however takes and blocks fall; several streams share a helper."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from shared.normals import NormalStream


def test_takes_are_the_generators_draws_in_order_across_blocks() -> None:
    direct = np.random.default_rng(4)
    stream = NormalStream(np.random.default_rng(4), 1000, "test-noise")
    for i, n in enumerate([7, 993, 1000, 250, 2600, 0, 1, 1500, 999]):
        got = stream.take(n)
        assert got.dtype == np.float32 and got.shape == (n,)
        assert np.array_equal(got, direct.standard_normal(n, dtype=np.float32)), (i, n)
        got[:3] = 0.0  # a caller may write into what it took (the MPC zeroes samples)
        if i % 2:
            stream.ahead()  # called once the values are in use (twice: no-op)
            stream.ahead()


def test_fixed_blocks_as_the_mpc_takes_them_and_two_streams_share_a_helper() -> None:
    shape = (50, 7, 2)
    size = int(np.prod(shape))
    a = NormalStream(np.random.default_rng(4), size, "test-noise")
    b = NormalStream(np.random.default_rng(9), size, "test-noise")
    da, db = np.random.default_rng(4), np.random.default_rng(9)
    for _ in range(6):
        got = a.take(size).reshape(shape)
        got[0] = 0.0
        assert np.array_equal(b.take(size).reshape(shape), db.standard_normal(shape, np.float32))
        want = da.standard_normal(shape, dtype=np.float32)
        assert np.array_equal(got[1:], want[1:])
        a.ahead()
    assert "test-noise" in {t.name for t in threading.enumerate()}


def test_a_block_must_hold_a_value() -> None:
    with pytest.raises(ValueError, match="block"):
        NormalStream(np.random.default_rng(0), 0, "test-noise")
