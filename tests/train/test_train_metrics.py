"""Each measure against its formula or a known value."""

from __future__ import annotations

import numpy as np
import pytest

from gesturebank.train.eval import metrics as M


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(42)


def test_cca_of_an_affine_image_is_one(rng: np.random.Generator) -> None:
    x = rng.normal(size=(200, 3))
    a = rng.normal(size=(3, 3)) + 3 * np.eye(3)
    assert M.cca(x, x @ a + np.array([1.0, -2.0, 5.0])) == pytest.approx(1.0, abs=1e-9)
    wide = rng.normal(size=(3, 5))  # into more dimensions
    assert M.cca(x, x @ wide + 7.0) == pytest.approx(1.0, abs=1e-9)


def test_cca_of_one_column_each_is_the_absolute_pearson_correlation(
    rng: np.random.Generator,
) -> None:
    x = rng.normal(size=500)
    y = -0.5 * x + rng.normal(size=500)
    assert M.cca(x, y) == pytest.approx(abs(np.corrcoef(x, y)[0, 1]), abs=1e-12)


def test_cca_directions_reach_rho(rng: np.random.Generator) -> None:
    x, y = rng.normal(size=(300, 4)), rng.normal(size=(300, 6))
    y[:, 0] += x[:, 1] - x[:, 2]
    a, b, rho = M.cca_directions(x, y)
    assert abs(np.corrcoef(x @ a, y @ b)[0, 1]) == pytest.approx(rho, abs=1e-9)  # Eq. 3.16
    assert M.cca(x, y) == pytest.approx(M.cca(y, x), abs=1e-12)


def test_cca_of_a_constant_is_zero(rng: np.random.Generator) -> None:
    x = rng.normal(size=(100, 3))
    assert M.cca(x, np.full((100, 11), 0.3)) == 0.0


def test_local_cca_of_independent_noise_is_near_zero(rng: np.random.Generator) -> None:
    x, y = rng.normal(size=3000), rng.normal(size=3000)
    assert M.local_cca(x, y, window=300, stride=1) < 0.1  # |r| of 300 independent pairs ~ 0.05
    assert M.local_cca(x, 2 * x + 1, window=300, stride=1) == pytest.approx(1.0)


def test_local_cca_is_the_mean_of_window_ccas(rng: np.random.Generator) -> None:
    x = rng.normal(size=(60, 3))
    y = x[:, :2] + rng.normal(size=(60, 2))
    n = 20
    direct = [M.cca(x[i : i + n], y[i : i + n]) for i in range(60 - n + 1)]  # Eq. 3.18
    values = M.local_cca_values(x, y, window=n, stride=1, chunk=7)
    assert len(values) == 60 - n + 1
    np.testing.assert_allclose(values, direct, atol=1e-9)
    assert M.local_cca(x, y, window=n, stride=1) == pytest.approx(np.mean(direct), abs=1e-9)
    assert M.local_cca_values(x, y, window=n, stride=5).shape == (9,)


def test_local_cca_of_a_short_sequence_uses_one_window(rng: np.random.Generator) -> None:
    x, y = rng.normal(size=(50, 2)), rng.normal(size=(50, 2))
    assert M.local_cca(x, y, window=300, stride=1) == pytest.approx(M.cca(x, y), abs=1e-9)


def test_lcca_measures_against_the_truth(rng: np.random.Generator) -> None:
    audio = rng.normal(size=(400, 5))
    true = audio[:, :3] @ rng.normal(size=(3, 11)) + 0.1 * rng.normal(size=(400, 11))
    assert M.lcca_theta(true, true, window=100, stride=1) == pytest.approx(1.0)  # Eq. 3.19
    assert M.delta_lcca(audio, true, pred=true, window=100, stride=1) == 0.0  # Eq. 3.20
    noise = rng.normal(size=(400, 11))
    expected = abs(
        M.local_cca(audio, true, window=100, stride=1)
        - M.local_cca(audio, noise, window=100, stride=1)
    )
    assert M.delta_lcca(audio, true, pred=noise, window=100, stride=1) == pytest.approx(expected)


def test_fcca_of_the_ground_truth_equals_its_cca(rng: np.random.Generator) -> None:
    audio = rng.normal(size=(500, 6))
    true = audio[:, :2] @ rng.normal(size=(2, 11)) + rng.normal(size=(500, 11))
    assert M.fcca(true, true, audio=audio) == pytest.approx(M.cca(true, audio), abs=1e-9)
    # An affine copy keeps the forced correlation; noise and a constant lose it.
    assert M.fcca(true, 3 * true - 1, audio=audio) == pytest.approx(M.cca(true, audio), abs=1e-9)
    assert M.fcca(true, rng.normal(size=(500, 11)), audio=audio) < 0.2
    assert M.fcca(true, np.full((500, 11), 0.7), audio=audio) == 0.0


def test_jerkiness_of_a_cubic(rng: np.random.Generator) -> None:
    f = 100.0
    t = np.arange(250) / f
    c = rng.normal(size=11)
    theta = t[:, None] ** 3 * c  # third derivative 6c everywhere; Δ³ is exact on a cubic
    expected = np.sum((6 * c) ** 2) * (250 - 3) / (2 * f * (250 - 3))  # Eq. 3.21
    assert M.jerkiness(theta, f) == pytest.approx(expected, rel=1e-6)
    quadratic = t[:, None] ** 2 * c + t[:, None] * 4
    assert M.jerkiness(quadratic, f) == pytest.approx(0.0, abs=1e-9)


def test_mean_jerkiness_over_sequences() -> None:
    f = 50.0
    t = np.arange(100) / f
    a = np.tile(t[:, None] ** 3, (1, 11))  # J = 11·36/(2f)
    b = np.zeros((100, 11))
    j_a = 11 * 36 / (2 * f)
    assert M.delta_jerkiness(a, b, rate_hz=f) == pytest.approx(j_a)
    j_mean, dj_mean = M.mean_jerkiness([a, a], [b, 2 * a], rate_hz=f)  # Eq. 3.22
    assert j_mean == pytest.approx((0 + 4 * j_a) / 2)
    assert dj_mean == pytest.approx((j_a + 3 * j_a) / 2)


def test_loss_rmse_and_ape_known_values() -> None:
    true = np.zeros((10, 11))
    pred = np.full((10, 11), 0.1)
    assert M.loss_l(true, pred) == pytest.approx(0.01)  # Eq. 3.15
    assert M.rmse(true, pred) == pytest.approx(0.1)  # Eq. 3.12
    np.testing.assert_allclose(M.rmse_per_joint(true, pred), 0.1)  # Eq. 3.11
    pred[:, 3] = 0.5
    assert M.rmse_per_joint(true, pred)[3] == pytest.approx(0.5)
    assert M.rmse(true, pred) == pytest.approx(np.sqrt((10 * 0.01 + 0.25) / 11))
    assert M.ape(true, pred) == pytest.approx((10 * 0.1 + 0.5) / 11)  # |·| on angles
    pos_t, pos_p = np.zeros((4, 2, 3)), np.zeros((4, 2, 3))
    pos_p[..., 0], pos_p[..., 1] = 3.0, 4.0
    assert M.ape(pos_t, pos_p) == pytest.approx(5.0)  # Eq. 1, Euclidean per joint


def test_loss_and_rmse_leave_out_unknown_truth() -> None:
    true = np.array([[0.0, np.nan], [0.0, 0.0]])
    pred = np.array([[0.2, 9.0], [0.2, 0.2]])
    assert M.loss_l(true, pred) == pytest.approx(0.04)
    assert M.rmse(true, pred) == pytest.approx(0.2)


def test_hellinger_identical_and_disjoint() -> None:
    h = np.array([0.2, 0.3, 0.5, 0.0])
    assert M.hellinger(h, h) == pytest.approx(0.0, abs=1e-7)
    assert M.hellinger([1.0, 0.0], [0.0, 1.0]) == pytest.approx(1.0)
    assert M.hellinger([1.0, 0.0], [0.5, 0.5]) == pytest.approx(np.sqrt(1 - np.sqrt(0.5)))  # Eq. 2


def test_speed_histogram() -> None:
    theta = np.array([[0.0], [0.001], [0.003], [0.1]])  # speeds 0.1, 0.2, 9.7 rad/s at 100 Hz
    s = M.speeds(theta, 100.0)
    np.testing.assert_allclose(s[:, 0], [0.1, 0.2, 9.7])
    h = M.speed_histogram(s, 0.15, top=1.5)
    assert h.shape == (10,) and h.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(h[[0, 1, 9]], [1 / 3, 1 / 3, 1 / 3])  # 9.7 clipped to the top bin
    assert M.speed_histogram([], 0.1, top=1.0).sum() == 0.0
