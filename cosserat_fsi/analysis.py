"""Periodic analysis of time series in the Turek-Hron convention.

A periodic result is "mean +- amplitude [frequency]" with mean = (max + min)/2 and amplitude =
(max - min)/2 (shared/reference/benchmarks.yaml), max and min over the last ``n_periods`` (2) periods: a
signal at twice the flag's frequency (FSI3's ux(A) and drag) alternates between two cycle shapes, one per
half swing of an asymmetric flag, and the last cycle alone would give one or the other depending on where
the record ends (measured on FSI3: ux(A) mean -4.6 / -8.9 %, drag amplitude +4.6 / -4.2 % in alternate
cycles); two periods hold both. Periods are cut at the
maxima of the dominant oscillation: a maximum is the largest sample of a complete excursion above
``mid + h`` entered from and left to below ``mid - h`` (hysteresis ``h`` = half the amplitude; the range
that of the last half, or of the last four periods when the last half begins with a larger transient), so
small harmonics do not create extra periods. Each maximum is refined by parabolic interpolation.

A signal with a step-scale roughness (the forces after each change of an adaptive step: docs/fsi3_table.md)
has its three-sample vertex on a spike; ``fit`` takes each extremum from the least-squares parabola through
the samples within ± ``fit`` × the period instead (at least five), for measuring how much of an amplitude is
that roughness. It is not the benchmark's convention, and the verdicts do not use it: the least-squares
parabola of a sine over ± 0.1 period lies 0.06 % of the amplitude below its top.

The samples need not be equally spaced (``time.tolerance`` chooses each step): the maxima are found in the
samples, the parabola goes through three samples at their times, the "last half" of the record is the last
half in time and the FFT cross-check interpolates to an equal spacing first.
"""

from __future__ import annotations

import numpy as np

_CONSTANT_RTOL = 1e-10


def second_half(t) -> int:
    """Index of the first sample of the last half of the record in time (``len(t) // 2`` for a uniform
    step; with steps chosen by time.tolerance the halves differ in their number of samples)."""
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        return 0
    middle = 0.5 * (t[0] + t[-1]) - 1e-9 * (t[-1] - t[0])
    return min(int(np.searchsorted(t, middle, side="left")), len(t) - 1)


def _vertex(t: np.ndarray, y: np.ndarray, i: int, half: float | None = None) -> tuple[float, float]:
    """Vertex of the parabola through samples i-1, i, i+1 (the sample itself at the ends); with ``half``, of
    the least-squares parabola through the samples within ``half`` of t[i] when there are at least five."""
    near = np.flatnonzero(np.abs(t - t[i]) <= half) if half is not None else []
    if len(near) < 5:
        if i == 0 or i == len(y) - 1:
            return float(t[i]), float(y[i])
        near = np.arange(i - 1, i + 2)
    dt = t[near] - t[i]
    c = np.polyfit(dt, y[near], 2)
    if c[0] == 0.0:
        return float(t[i]), float(y[i])
    tv = float(np.clip(-c[1] / (2 * c[0]), dt[0], dt[-1]))
    return float(t[i] + tv), float(np.polyval(c, tv))


def _cycle_maxima(y: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Index of the largest sample of every complete excursion from below ``lo`` to above ``hi``
    and back below ``lo``."""
    state = np.where(y > hi, 1, np.where(y < lo, -1, 0))
    idx = np.flatnonzero(state)
    s = state[idx]
    flips = np.flatnonzero(s[1:] != s[:-1]) + 1
    rises, falls = idx[flips[s[flips] == 1]], idx[flips[s[flips] == -1]]
    j = np.searchsorted(falls, rises)
    rises, ends = rises[j < len(falls)], falls[j[j < len(falls)]]
    return np.array([a + int(np.argmax(y[a:b])) for a, b in zip(rises, ends)], dtype=int)


def _levels(y: np.ndarray) -> tuple[float, float]:
    mid, half = (y.max() + y.min()) / 2, (y.max() - y.min()) / 2
    return mid - half / 2, mid + half / 2


def cycle_peaks(y: np.ndarray, part: np.ndarray) -> np.ndarray:
    """Index of the maximum of every complete cycle of ``y``, a cycle an excursion across the middle half
    of the range of ``part`` (a part of ``y``, e.g. its periodic tail)."""
    return _cycle_maxima(y, *_levels(part))


LEVEL_PERIODS = 4
"""The cycles are cut with the levels of the last ``LEVEL_PERIODS`` periods (of the FFT frequency)."""


def _recent(t: np.ndarray, y: np.ndarray, half: int, frequency: float | None) -> np.ndarray:
    """The part of the record whose range sets the levels that cut the cycles when the last half's range does
    not (its last cycle ends more than two cycles before the record): the last ``LEVEL_PERIODS`` periods, or
    the last half when that holds fewer than twice as many. A larger excursion early in the last half (a
    transient not yet settled) sets levels that the settled cycles do not cross, and the "last" cycles found
    would be the transient's (measured: FSI3 on the 8-across flag at a fixed step, whose last half began with
    the end of a larger swing at t = 4.0–4.25)."""
    if frequency is None or frequency * (t[-1] - t[half]) < 2 * LEVEL_PERIODS:
        return y[half:]
    return y[t >= t[-1] - LEVEL_PERIODS / frequency]


def cycle_extrema(t: np.ndarray, y: np.ndarray, peaks: np.ndarray,
                  fit: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The maxima at ``peaks`` and the minimum between each two, parabola vertices through the samples:
    (times of the maxima, their values, the minima), of lengths n, n and n − 1. ``fit``: each extremum from
    the least-squares parabola over ± ``fit`` × the mean cycle (module docstring)."""
    half = None if fit is None or len(peaks) < 2 else fit * float(np.mean(np.diff(t[peaks])))
    tops = [_vertex(t, y, i, half) for i in peaks]
    bottoms = [-_vertex(t, -y, a + int(np.argmin(y[a:b + 1])), half)[1] for a, b in zip(peaks[:-1], peaks[1:])]
    return (np.array([tv for tv, _ in tops]), np.array([yv for _, yv in tops]), np.array(bottoms))


def _fft_frequency(t: np.ndarray, y: np.ndarray) -> float | None:
    """Dominant frequency of a detrended, Hann-windowed, zero-padded FFT (Gaussian peak fit)."""
    n = len(t)
    tu = np.linspace(t[0], t[-1], n)
    yu = np.interp(tu, t, y)
    yu = yu - np.polyval(np.polyfit(tu, yu, 1), tu)
    spec = np.abs(np.fft.rfft(yu * np.hanning(n), n=16 * n))
    freqs = np.fft.rfftfreq(16 * n, tu[1] - tu[0])
    k = int(np.argmax(spec[16:])) + 16  # skip the lowest bins (less than one period in the record)
    if k >= len(spec) - 1 or spec[k] == 0.0:
        return None
    la, lb, lc = np.log(spec[k - 1:k + 2] + 1e-300)
    shift = 0.5 * (la - lc) / (la - 2 * lb + lc) if la - 2 * lb + lc != 0 else 0.0
    return float(freqs[k] + shift * (freqs[1] - freqs[0]))


def periodic_analysis(t, y, n_periods: int = 2, fit: float | None = None) -> dict:
    """Mean, amplitude and frequency of the periodic tail of ``y(t)``.

    Returns ``dict(mean, amplitude, frequency, periods_used, frequency_fft, method)``:
    ``frequency`` = ``n_periods`` / (time between the last ``n_periods + 1`` maxima); mean and amplitude
    from the max and min over those ``n_periods`` periods; ``frequency_fft`` is the FFT estimate over the
    last half of the record (cross-check). Without enough maxima the FFT frequency is used if the last
    half holds more than ``n_periods`` periods (``method="fft"``, mean/amplitude over the last 1/f);
    otherwise every field is None (``method=None``). A constant tail gives amplitude 0 and frequency
    None (``method="constant"``). ``fit``: the extrema from least-squares parabolas over ± ``fit`` × the
    period (module docstring); the verdicts use the default, the three-sample vertex.
    """
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    if t.ndim != 1 or t.shape != y.shape or len(t) < 3 or np.any(np.diff(t) <= 0):
        raise ValueError("periodic_analysis: t and y must be 1-D of equal length >= 3, t increasing")
    if n_periods < 1:
        raise ValueError("periodic_analysis: n_periods must be >= 1")
    half = second_half(t)
    tail = y[half:]
    result = dict(mean=None, amplitude=None, frequency=None, periods_used=0, frequency_fft=None,
                  method=None)
    if np.ptp(tail) <= _CONSTANT_RTOL * max(np.abs(tail).max(), np.finfo(float).tiny):
        return result | dict(mean=float(tail.mean()), amplitude=0.0, method="constant")
    result["frequency_fft"] = _fft_frequency(t[half:], tail)

    peaks = cycle_peaks(y, tail)
    if len(peaks) >= 2 and t[-1] - t[peaks[-1]] > 2 * np.mean(np.diff(t[peaks])):
        peaks = cycle_peaks(y, _recent(t, y, half, result["frequency_fft"]))  # the tail's range was a transient's
    if len(peaks) >= 3:  # refine the levels on the last two cycles
        peaks = cycle_peaks(y, y[peaks[-3]:peaks[-1] + 1])
    if len(peaks) >= n_periods + 1:
        tm, tops, bottoms = cycle_extrema(t, y, peaks[-n_periods - 1:], fit)
        ymax, ymin = float(tops.max()), float(bottoms.min())
        return result | dict(mean=(ymax + ymin) / 2, amplitude=(ymax - ymin) / 2,
                             frequency=float(n_periods / (tm[-1] - tm[0])), periods_used=n_periods,
                             method="maxima")

    f = result["frequency_fft"]
    if f is not None and f * (t[-1] - t[half]) > n_periods + 1:
        last = y[t >= t[-1] - 1 / f]
        return result | dict(mean=(last.max() + last.min()) / 2,
                             amplitude=(last.max() - last.min()) / 2, frequency=f,
                             periods_used=int(f * (t[-1] - t[half])), method="fft")
    return result


def relative_error(value: float, reference: float) -> float:
    """|value - reference| / |reference|; raises ValueError for a zero reference."""
    if reference == 0:
        raise ValueError("relative_error: reference is 0, use an absolute error")
    return abs(value - reference) / abs(reference)
