import numpy as np

from master_side.slam.particle_filter import needs_resampling, neff, normalized_weights, systematic_resample


def test_weights_are_normalised_even_for_huge_log_weights():
    w = normalized_weights(np.array([-1e6, -1e6 + 3.0, -1e6 + 1.0]), gain=1.0)
    assert np.isclose(w.sum(), 1.0)
    assert np.argmax(w) == 1


def test_neff_is_n_for_uniform_and_one_for_degenerate_weights():
    assert np.isclose(neff(np.full(10, 0.1)), 10.0)
    assert np.isclose(neff(np.eye(1, 10)[0]), 1.0)
    assert not needs_resampling(np.full(10, 0.1), 0.5)
    assert needs_resampling(np.eye(1, 10)[0], 0.5)


def test_resampling_keeps_the_count_and_follows_the_weights():
    rng = np.random.default_rng(3)
    w = np.array([0.7, 0.1, 0.1, 0.1, 0.0])
    counts = np.zeros(5)
    for _ in range(200):
        idx = systematic_resample(w, rng)
        assert len(idx) == 5
        counts += np.bincount(idx, minlength=5)
    assert counts[4] == 0
    assert np.allclose(counts / counts.sum(), w, atol=0.03)


def test_smoothing_gain_flattens_the_weights():
    lw = np.array([0.0, -10.0])
    assert neff(normalized_weights(lw, 0.01)) > neff(normalized_weights(lw, 1.0))
