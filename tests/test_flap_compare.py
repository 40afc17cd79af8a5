"""examples/perpendicular_flap/compare.py: first peak and period of a tip signal, a wiggle near a crest not
counted as a period (the δt = 0.005 run has one near t = 2.25)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

_PATH = Path(__file__).resolve().parents[1] / "examples" / "perpendicular_flap" / "compare.py"
_SPEC = importlib.util.spec_from_file_location("flap_compare", _PATH)
compare = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(compare)


def test_a_wiggle_at_a_crest_is_not_a_period():
    t = np.arange(0.0, 5.0, 0.005)
    u = 0.1 - 0.1 * np.cos(2 * np.pi * t / 1.6)  # period 1.6, first crest 0.2 at t = 0.8
    u += 0.002 * np.exp(-((t - 2.4) / 0.03) ** 2) * np.sin(2 * np.pi * (t - 2.4) / 0.05)  # a wiggle at the crest
    assert len(compare.peaks(t, u)) > 3  # the local maxima see the wiggle
    s = compare.summary(t, u)
    assert s["n_peaks"] == 3 and s["period"] == pytest.approx(1.6, rel=1e-3)
    assert s["t_peak"] == pytest.approx(0.8, abs=1e-3) and s["peak"] == pytest.approx(0.2, rel=1e-4)
