import numpy as np

from common.geometry import Pose2D
from master_side.slam.motion_model import MotionModel, relative


def test_samples_have_the_model_mean_and_standard_deviation():
    mm = MotionModel(srr=0.1, srt=0.2, str_=0.1, stt=0.2)
    delta = np.array([0.5, 0.1, 0.2])
    rng = np.random.default_rng(1)
    n = 20000
    out = mm.sample(np.zeros((n, 3)), delta, rng)  # start at the origin: output = noisy increment
    want = mm.sigmas(delta)
    assert np.allclose(out.mean(axis=0), delta, atol=4 * want / np.sqrt(n) + 1e-3)
    assert np.allclose(out.std(axis=0), want, rtol=0.05)


def test_noise_grows_with_the_motion_and_vanishes_without_motion():
    mm = MotionModel(0.1, 0.2, 0.1, 0.2)
    rng = np.random.default_rng(2)
    still = mm.sample(np.tile([1.0, 2.0, 0.5], (100, 1)), np.zeros(3), rng)
    assert np.allclose(still, [1.0, 2.0, 0.5])
    assert (mm.sigmas(np.array([1.0, 0, 0])) > mm.sigmas(np.array([0.1, 0, 0]))).all()


def test_increment_is_applied_in_the_particle_frame():
    mm = MotionModel(0.0, 0.0, 0.0, 0.0)
    d = relative(Pose2D(1, 1, 0.0), Pose2D(2, 1, 0.0))
    out = mm.sample(np.array([[0.0, 0.0, np.pi / 2]]), d, np.random.default_rng(0))
    assert np.allclose(out[0], [0.0, 1.0, np.pi / 2])
