"""Periodic analysis on synthetic signals (Turek-Hron convention: mean/amplitude from max/min)."""

import numpy as np
import pytest

from cosserat_fsi.analysis import periodic_analysis, relative_error

T = np.arange(0.0, 3.0 + 1e-12, 1e-3)
W = 2 * np.pi * 4.4


def test_sine():
    r = periodic_analysis(T, 3 + 2 * np.sin(W * T))
    assert r["mean"] == pytest.approx(3, abs=1e-3)
    assert r["amplitude"] == pytest.approx(2, abs=1e-3)
    assert r["frequency"] == pytest.approx(4.4, rel=1e-3)
    assert r["frequency_fft"] == pytest.approx(4.4, rel=1e-3)
    assert r["periods_used"] == 2 and r["method"] == "maxima"


def test_decaying_transient_then_periodic():
    y = 3 + 2 * np.sin(W * T) + 5 * np.exp(-T / 0.2) * (1 + np.sin(17 * T))
    r = periodic_analysis(T, y, n_periods=3)
    assert r["mean"] == pytest.approx(3, abs=1e-3)
    assert r["amplitude"] == pytest.approx(2, abs=1e-3)
    assert r["frequency"] == pytest.approx(4.4, rel=1e-3)
    assert r["periods_used"] == 3


def test_second_harmonic_keeps_fundamental():
    """Lift-like: a strong second harmonic adds a shoulder, not an extra period."""
    y = 1 + np.sin(W * T) + 0.4 * np.sin(2 * W * T + 0.3)
    tail = y[T > 1]
    r = periodic_analysis(T, y)
    assert r["frequency"] == pytest.approx(4.4, rel=1e-3)
    assert r["mean"] == pytest.approx((tail.max() + tail.min()) / 2, abs=1e-4)
    assert r["amplitude"] == pytest.approx((tail.max() - tail.min()) / 2, abs=1e-4)


def test_drag_like_at_twice_the_frequency():
    """Drag oscillates at twice the lift frequency, with its own harmonic."""
    y = 460 + 27 * np.sin(2 * W * T) + 3 * np.sin(4 * W * T + 0.5)
    tail = y[T > 1]
    r = periodic_analysis(T, y)
    assert r["frequency"] == pytest.approx(8.8, rel=1e-3)
    assert r["mean"] == pytest.approx((tail.max() + tail.min()) / 2, abs=1e-3)
    assert r["amplitude"] == pytest.approx((tail.max() - tail.min()) / 2, abs=1e-3)
    # a weak component at the lift frequency does not double the period
    assert periodic_analysis(T, y + 1.0 * np.sin(W * T))["frequency"] == pytest.approx(8.8, rel=1e-3)


def test_alternating_cycles_give_the_envelope_wherever_the_record_ends():
    """A 2f signal with a 1f component (FSI3's ux(A), drag: the flag swings further to one side) alternates
    between two cycle shapes (minima -5.4 and -6.0 here); mean and amplitude are those of both, whichever
    cycle is last. Exact: max -3 + 2.7 + 0.3²/21.6 at sin θ = 1/36, min -6."""
    y = -3 + 2.7 * np.cos(2 * W * T) + 0.3 * np.sin(W * T)
    top, bottom = -0.3 + 0.3 ** 2 / 21.6, -6.0
    for end in (2.9, 2.9 + 1 / 8.8):  # the record ends after one cycle shape, then after the other
        keep = T <= end
        r = periodic_analysis(T[keep], y[keep])
        assert r["frequency"] == pytest.approx(8.8, rel=1e-3)
        assert r["mean"] == pytest.approx((top + bottom) / 2, abs=1e-5)
        assert r["amplitude"] == pytest.approx((top - bottom) / 2, abs=1e-5)


def test_a_larger_swing_early_in_the_last_half_does_not_hide_the_last_periods():
    """The last half begins with the end of a larger swing (8-across FSI3 at a fixed step: ux(A) down to −7.8 mm
    at t = 4.0–4.25, then settled cycles between −5.76 and −0.19 mm): levels taken from the whole last half
    lie outside the settled cycles, and the analysis took two periods of the transient (there: mean −4.03 mm,
    amplitude 3.79 mm; here −4.24 / 4.06). The last periods' own levels give the settled values."""
    t = np.arange(0.0, 8.0 + 1e-12, 2.5e-3)
    theta = 2 * np.pi * 10.9 * t
    deeper = 3.0 * np.exp(-((t - 4.0) / 0.2) ** 2) * (1 - np.cos(theta)) / 2  # deeper minima about t = 4
    y = -2.97 + 2.79 * np.cos(theta) - deeper
    assert y[t >= 4.0].min() < -8.2
    r = periodic_analysis(t, y)
    assert r["mean"] == pytest.approx(-2.97, abs=1e-4)
    assert r["amplitude"] == pytest.approx(2.79, abs=1e-4)
    assert r["frequency"] == pytest.approx(10.9, rel=1e-4)


def test_constant():
    r = periodic_analysis(T, np.full_like(T, 7.0))
    assert r["mean"] == 7.0 and r["amplitude"] == 0.0 and r["frequency"] is None


def test_too_short_gives_none():
    short = T < 0.4  # 1.76 periods
    r = periodic_analysis(T[short], np.sin(W * T[short]))
    assert r["mean"] is None and r["amplitude"] is None and r["frequency"] is None
    assert periodic_analysis(T, np.exp(-T))["frequency"] is None  # monotone: no period at all


def test_fft_fallback_on_drift():
    """A drift larger than the oscillation leaves no clean maxima cycles: the FFT gives f."""
    r = periodic_analysis(T, 5 * T + np.sin(W * T))
    assert r["method"] == "fft"
    assert r["frequency"] == pytest.approx(4.4, rel=1e-3)


def test_nonuniform_sampling():
    t = np.sort(np.random.default_rng(0).uniform(0, 3, 4000))
    r = periodic_analysis(t, 3 + 2 * np.sin(W * t))
    assert r["frequency"] == pytest.approx(4.4, rel=1e-3)
    assert r["amplitude"] == pytest.approx(2, abs=1e-3)


def test_the_fitted_extrema_see_through_step_scale_spikes_the_vertex_reads():
    """Spikes of 2 % of the amplitude on every third sample (the forces after each change of an adaptive step):
    the three-sample vertex puts the amplitude up by about the spike; the least-squares parabola over ± 0.1
    period stays within its 0.06 % bias of a clean sine, which it also keeps without spikes."""
    t = np.arange(0.0, 3.0 + 1e-12, 2e-3)
    clean = 3 + 2 * np.sin(W * t)
    spiky = clean + 0.04 * (np.arange(len(t)) % 3 == 0)
    assert periodic_analysis(t, spiky)["amplitude"] > 2.015
    for y, mean in ((clean, 3.0), (spiky, 3 + 0.04 / 3)):  # the spikes' own mean shifts the signal's
        r = periodic_analysis(t, y, fit=0.1)
        assert r["amplitude"] == pytest.approx(2 * (1 - 0.00055), abs=0.002)
        assert r["mean"] == pytest.approx(mean, abs=0.002)
        assert r["frequency"] == pytest.approx(4.4, rel=1e-3)


def test_a_fit_with_fewer_than_five_samples_in_its_window_is_the_vertex():
    t = np.arange(0.0, 3.0 + 1e-12, 1e-2)
    y = 3 + 2 * np.sin(W * t)
    assert periodic_analysis(t, y, fit=0.01) == periodic_analysis(t, y)


def test_bad_input():
    with pytest.raises(ValueError):
        periodic_analysis([0, 1], [0, 1])
    with pytest.raises(ValueError):
        periodic_analysis(T, T[:-1])


def test_relative_error():
    assert relative_error(101.0, 100.0) == pytest.approx(0.01)
    assert relative_error(-99.0, -100.0) == pytest.approx(0.01)
    with pytest.raises(ValueError):
        relative_error(1.0, 0.0)
