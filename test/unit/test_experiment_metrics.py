"""Wolpaw bits per selection."""

import math

import pytest

from eye_bci_ros2.experiments.metrics import wolpaw_bits


def test_wolpaw_bits():
    assert wolpaw_bits(4, 1.0) == 2.0
    assert wolpaw_bits(4, 0.25) == 0.0
    assert wolpaw_bits(4, 0.1) == 0.0
    assert wolpaw_bits(1, 1.0) == 0.0
    # Wolpaw 2000's example values: N = 2, P = 0.9 -> 0.531 bits.
    assert wolpaw_bits(2, 0.9) == pytest.approx(0.531, abs=1e-3)
    p = 0.8
    assert wolpaw_bits(8, p) == pytest.approx(
        3 + p * math.log2(p) + (1 - p) * math.log2((1 - p) / 7))
    with pytest.raises(ValueError):
        wolpaw_bits(4, 1.5)
