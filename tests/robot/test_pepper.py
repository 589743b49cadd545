"""Pepper joints, profiles, limits, normalisation and forward kinematics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from gesturebank.errors import InputError
from gesturebank.robot import pepper

# Typed from the dissertation (seed 000, §3.1.1 and Table 3.1), not read from the package.
DISSERTATION_ORDER = [
    "HeadPitch",
    "HeadYaw",
    "LShoulderRoll",
    "LShoulderPitch",
    "LElbowRoll",
    "LElbowYaw",
    "RShoulderRoll",
    "RShoulderPitch",
    "RElbowRoll",
    "RElbowYaw",
    "HipRoll",
]
TABLE_3_1 = {
    "HeadPitch": (-0.7068, 0.4451),
    "HeadYaw": (-2.0857, 2.0857),
    "LShoulderRoll": (0.0087, 1.5620),
    "LShoulderPitch": (-2.0857, 2.0857),
    "LElbowRoll": (-1.5620, -0.0087),
    "LElbowYaw": (-2.0857, 2.0857),
    "RShoulderRoll": (-1.5620, -0.0087),
    "RShoulderPitch": (-2.0857, 2.0857),
    "RElbowRoll": (0.0087, 1.5620),
    "RElbowYaw": (-2.0857, 2.0857),
    "HipRoll": (-0.5149, 0.5149),
}
PROFILES = ["pepper-1.7", "pepper-1.8"]


def test_joint_order_is_the_dissertations():
    assert list(pepper.JOINTS) == DISSERTATION_ORDER


def test_default_profile_is_table_3_1():
    p = pepper.load_profile()
    assert p.name == "pepper-1.7"
    for i, j in enumerate(DISSERTATION_ORDER):
        assert (p.lower[i], p.upper[i]) == pytest.approx(TABLE_3_1[j], abs=1e-9)


def test_pepper_1_8_has_urdf_head_pitch_and_velocities():
    p = pepper.load_profile("pepper-1.8")
    hp = DISSERTATION_ORDER.index("HeadPitch")
    assert p.upper[hp] == pytest.approx(0.6370, abs=1e-4)
    assert p.lower[hp] == pytest.approx(-0.7069, abs=1e-4)
    # URDF velocities: pitch/yaw motors 7.34 rad/s, roll motors 9.23 rad/s, HipRoll 2.27 rad/s.
    expect = {"LShoulderPitch": 7.34, "LShoulderRoll": 9.23, "RElbowYaw": 7.34, "HipRoll": 2.27}
    for j, v in expect.items():
        assert p.velocity[DISSERTATION_ORDER.index(j)] == pytest.approx(v, abs=0.01)


def test_unknown_profile_lists_known_ones():
    with pytest.raises(InputError) as err:
        pepper.load_profile("nao-6")
    assert "nao-6" in str(err.value)
    for name in PROFILES:
        assert name in str(err.value)


def test_neutral_pose():
    n = pepper.neutral_pose()
    assert n.shape == (11,)
    expected = np.zeros(11)
    expected[[3, 7]] = np.pi / 2
    np.testing.assert_allclose(n, expected, atol=1e-7)


@pytest.mark.parametrize("fn", [pepper.clamp, pepper.normalise, pepper.denormalise, pepper.fk])
def test_wrong_shape_is_input_error(fn):
    with pytest.raises(InputError, match=r"\(N, 11\)"):
        fn(np.zeros((4, 10)))


# --------------------------------------------------------------------------------------------------
# Clamping and velocity limiting

angle_rows = arrays(
    np.float64,
    st.tuples(st.integers(1, 40), st.just(11)),
    elements=st.one_of(st.floats(-10, 10), st.just(np.nan)),
)


@settings(max_examples=200, deadline=None)
@given(a=angle_rows, name=st.sampled_from(PROFILES))
def test_clamp_stays_in_limits_and_keeps_nan(a, name):
    p = pepper.load_profile(name)
    out = pepper.clamp(a, name)
    finite = ~np.isnan(a)
    assert np.array_equal(np.isnan(out), ~finite)
    lo = np.broadcast_to(p.lower, a.shape)[finite]
    hi = np.broadcast_to(p.upper, a.shape)[finite]
    assert np.all(out[finite] >= lo) and np.all(out[finite] <= hi)
    inside = finite & (a >= p.lower) & (a <= p.upper)
    np.testing.assert_array_equal(out[inside], a[inside])


@settings(max_examples=200, deadline=None)
@given(a=angle_rows, dt=st.floats(0.001, 0.1))
def test_velocity_limit_bounds_every_step(a, dt):
    p = pepper.load_profile()
    out = pepper.limit_velocity(a, dt, profile=p).astype(np.float64)
    assert np.array_equal(np.isnan(out), np.isnan(a))
    # Per joint, between consecutive valid samples k < m: |Δ| ≤ v · (m − k) · dt.
    for col in range(11):
        idx = np.flatnonzero(~np.isnan(out[:, col]))
        steps = np.abs(np.diff(out[idx, col]))
        allowed = p.velocity[col] * np.diff(idx) * dt
        assert np.all(steps <= allowed * (1 + 1e-6) + 1e-5)


def test_velocity_limit_leaves_slow_motion_alone():
    t = np.linspace(0, 2, 201)
    slow = 0.5 * np.sin(2 * np.pi * 0.5 * t)[:, None] * np.ones(11)  # peak 1.57 rad/s
    np.testing.assert_allclose(pepper.limit_velocity(slow, 0.01), slow, atol=1e-6)


def test_velocity_limit_ramps_a_step_at_full_speed():
    v = pepper.load_profile().velocity
    a = np.zeros((50, 11))
    a[10:] = 1.0  # 1 rad step at sample 10
    out = pepper.limit_velocity(a, dt=0.01)
    # After the step, each joint rises by v·dt per sample until it reaches 1.
    k = np.arange(1, 41)[:, None]
    np.testing.assert_allclose(out[10:], np.minimum(1.0, k * v * 0.01), atol=1e-6)


def test_velocity_limit_with_timestamps_and_start():
    v = pepper.load_profile().velocity
    ts = np.array([0.0, 0.01, 0.05])
    a = np.full((3, 11), 2.0)
    out = pepper.limit_velocity(a, timestamps=ts, start=np.zeros(11))
    # `start` is one step (0.01 s) before the first sample.
    np.testing.assert_allclose(out[0], np.minimum(2.0, v * 0.01), atol=1e-6)
    np.testing.assert_allclose(out[2], np.minimum(2.0, v * 0.06), atol=1e-6)


def test_velocity_limit_needs_dt_or_timestamps():
    with pytest.raises(InputError):
        pepper.limit_velocity(np.zeros((3, 11)))


# --------------------------------------------------------------------------------------------------
# Normalisation (Eq. 3.13–3.14)


@pytest.mark.parametrize("name", PROFILES)
def test_normalise_is_exact_at_the_limits(name):
    p = pepper.load_profile(name)
    np.testing.assert_array_equal(pepper.normalise(p.lower[None], name), np.zeros((1, 11)))
    np.testing.assert_array_equal(pepper.normalise(p.upper[None], name), np.ones((1, 11)))
    mid = (p.lower + p.upper) / 2
    np.testing.assert_allclose(pepper.normalise(mid[None], name), 0.5, atol=1e-6)
    np.testing.assert_allclose(pepper.denormalise(np.zeros((1, 11)), name)[0], p.lower, atol=1e-6)
    np.testing.assert_allclose(pepper.denormalise(np.ones((1, 11)), name)[0], p.upper, atol=1e-6)


def test_normalise_hand_value():
    # HeadPitch 0 in Table 3.1: (0 + 0.7068) / (0.4451 + 0.7068) = 0.61359...
    out = pepper.normalise(np.zeros((1, 11)))
    assert out[0, 0] == pytest.approx(0.7068 / (0.4451 + 0.7068), abs=1e-6)


@settings(max_examples=100, deadline=None)
@given(u=arrays(np.float64, (5, 11), elements=st.floats(0, 1)), name=st.sampled_from(PROFILES))
def test_normalise_round_trip(u, name):
    p = pepper.load_profile(name)
    a = p.lower + u * (p.upper - p.lower)
    back = pepper.denormalise(pepper.normalise(a, name), name)
    np.testing.assert_allclose(back, a, atol=1e-5)
    np.testing.assert_allclose(pepper.normalise(a, name), u, atol=1e-6)


# --------------------------------------------------------------------------------------------------
# Forward kinematics


def _pose(**kw: float) -> np.ndarray:
    a = pepper.neutral_pose().astype(np.float64)
    for name, value in kw.items():
        a[DISSERTATION_ORDER.index(name)] = value
    return a[None]


def test_urdf_arm_length_matches_pybullet():
    # offline-resources §C3: pybullet on the stripped URDF gives shoulder→wrist 0.3305 m at zero.
    pts = pepper.fk(np.zeros((1, 11)), model="urdf")
    for side in ("left", "right"):
        d = np.linalg.norm(pts[f"{side}_wrist"] - pts[f"{side}_shoulder"])
        assert d == pytest.approx(0.3305, abs=5e-4)
    assert pts["left_shoulder"][0] == pytest.approx([-0.057, 0.14974, 0.22582])
    assert pts["right_shoulder"][0] == pytest.approx([-0.057, -0.14974, 0.22582])


@pytest.mark.parametrize("model", ["urdf", "ideal"])
def test_fk_signs_follow_naoqi(model):
    def pts(**kw: float) -> dict[str, np.ndarray]:
        return {k: v[0] for k, v in pepper.fk(_pose(**kw), model=model).items()}

    hanging = pts()
    # Arms hanging at ShoulderPitch = π/2: wrists below the shoulders.
    for side in ("left", "right"):
        drop = hanging[f"{side}_shoulder"][2] - hanging[f"{side}_wrist"][2]
        assert drop > 0.3
    forward = pts(LShoulderPitch=0.0, RShoulderPitch=0.0)
    assert forward["left_wrist"][0] - forward["left_shoulder"][0] > 0.3
    raised = pts(LShoulderPitch=-np.pi / 2)
    assert raised["left_wrist"][2] - raised["left_shoulder"][2] > 0.3
    # Roll away from the body: left arm to +y, right arm to −y.
    out = pts(LShoulderRoll=1.0, RShoulderRoll=-1.0)
    assert out["left_elbow"][1] > hanging["left_elbow"][1] + 0.1
    assert out["right_elbow"][1] < hanging["right_elbow"][1] - 0.1
    # Elbow bent (L < 0, R > 0) with arms forward: forearms turn inwards.
    bent = pts(LShoulderPitch=0.0, RShoulderPitch=0.0, LElbowRoll=-1.0, RElbowRoll=1.0)
    assert bent["left_wrist"][1] < forward["left_wrist"][1] - 0.1
    assert bent["right_wrist"][1] > forward["right_wrist"][1] + 0.1
    # Head: yaw + to the left, pitch + down.
    assert pts(HeadYaw=0.5)["nose"][1] > 0.03
    assert pts(HeadPitch=0.4)["nose"][2] < hanging["nose"][2] - 0.03
    # HipRoll + : the upper body leans to its left (URDF axis −x).
    lean = pts(HipRoll=0.3)
    assert lean["head"][1] > 0.05
    np.testing.assert_allclose(lean["left_hip"], hanging["left_hip"])


@settings(max_examples=100, deadline=None)
@given(u=arrays(np.float64, (8, 11), elements=st.floats(0, 1)))
def test_fk_bone_lengths_do_not_depend_on_angles(u):
    p = pepper.load_profile()
    pts = pepper.fk(p.lower + u * (p.upper - p.lower), model="urdf")
    for side in ("left", "right"):
        upper = np.linalg.norm(pts[f"{side}_elbow"] - pts[f"{side}_shoulder"], axis=1)
        fore = np.linalg.norm(pts[f"{side}_wrist"] - pts[f"{side}_elbow"], axis=1)
        np.testing.assert_allclose(upper, np.hypot(np.hypot(0.1812, 0.015), 0.00013), rtol=1e-9)
        np.testing.assert_allclose(fore, 0.15, rtol=1e-9)


@settings(max_examples=100, deadline=None)
@given(
    u=arrays(np.float64, (8, 11), elements=st.floats(0, 1)),
    model=st.sampled_from(["urdf", "ideal"]),
)
def test_fk_mirror_symmetry(u, model):
    p = pepper.load_profile()
    a = p.lower + u * (p.upper - p.lower)
    # Mirror y → −y: swap arms, negate roll and yaw joints, keep pitches.
    m = a[:, [0, 1, 6, 7, 8, 9, 2, 3, 4, 5, 10]] * [1, -1, -1, 1, -1, -1, -1, 1, -1, -1, -1]
    pa, pm = pepper.fk(a, model=model), pepper.fk(m, model=model)
    flip = np.array([1.0, -1.0, 1.0])
    for name in ("shoulder", "elbow", "wrist", "eye", "ear"):
        np.testing.assert_allclose(pm[f"right_{name}"], pa[f"left_{name}"] * flip, atol=1e-12)
    np.testing.assert_allclose(pm["nose"], pa["nose"] * flip, atol=1e-12)


def test_fk_coco17_layout():
    j = pepper.fk_coco17(np.zeros((3, 11)), model="ideal")
    assert j.shape == (3, 17, 3)
    assert np.isnan(j[:, 13:]).all()  # knees, ankles
    assert np.isfinite(j[:, :13]).all()


def test_clamped_float32_never_exceeds_the_float64_limits() -> None:
    """float32(2.0857) > 2.0857: clamping a float32 array must still land inside the limits."""
    p = pepper.load_profile("pepper-1.7")
    far = np.stack([p.lower - 1, p.upper + 1]).astype(np.float32)
    out = pepper.clamp(far, p)
    assert out.dtype == np.float32
    assert np.all(out.astype(np.float64) >= p.lower)
    assert np.all(out.astype(np.float64) <= p.upper)
    np.testing.assert_allclose(out, np.stack([p.lower, p.upper]), atol=1e-6)
