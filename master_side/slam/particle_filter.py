"""Particle weights, effective sample size and low-variance resampling (pure functions)."""

from __future__ import annotations

import numpy as np


def normalized_weights(log_weights: np.ndarray, gain: float) -> np.ndarray:
    """gmapping's smoothing: w_i ∝ exp(gain * (l_i - max l)), returned summing to one."""
    lw = np.asarray(log_weights, float)
    w = np.exp(gain * (lw - lw.max()))
    return w / w.sum()


def neff(weights: np.ndarray) -> float:
    """Effective sample size 1 / sum(w^2) of normalised weights (N for uniform, 1 for degenerate)."""
    return float(1.0 / np.sum(np.square(weights)))


def needs_resampling(weights: np.ndarray, threshold: float) -> bool:
    """Resample when Neff < threshold * N (gmapping's resampleThreshold)."""
    return neff(weights) < threshold * len(weights)


def systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Indices of the surviving particles (low-variance sampler, one random offset)."""
    n = len(weights)
    positions = (rng.random() + np.arange(n)) / n
    cum = np.cumsum(weights)
    cum[-1] = 1.0
    return np.searchsorted(cum, positions, side="right").clip(0, n - 1)
