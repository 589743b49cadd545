"""Cameras and 2D error of the `learned` lifter's training pairs (issue 39): people filmed as people
film them, and keypoints as BlazePose gives them.

Cameras (`CameraRanges`): from seated to ceiling height (−0.5…+1.2 m from the chest), pitched to
the person, 1.2–6 m away, 35–100° across the image (landscape or portrait), turned and rolled so
the person sits anywhere in the picture, partly outside it; some with a lens's barrel distortion.
A stretch gets several candidate cameras at once and keeps the first in which its shoulders stay in
the picture and no joint comes nearer than MIN_DEPTH_M. The geometry is kornia's, batched in torch
(rotations from axis-angle, pinhole projection, lens distortion).

The lifter reads the pixels as rays with the calibrated camera (undistorted) or, without one,
with a focal from `[fitted] fov_deg` across the longer side (lift.fitted.pinhole): half the pairs
are read each way, so the net sees the wrong focal and lens it will meet.

2D error (`detector_noise`), in the person's spine lengths in the image: BlazePose's per-joint
drift and bias measured on the project's renders (`NOISE_SD`, `NOISE_BIAS_Y`), larger for
fast-moving joints (blur) and for joints outside the picture (the detector guesses them); short
runs of left and right exchanged (`SWAP_RATE`, issue 39: BlazePose run on each frame of a
fast-motion render exchanged them in 1.3 % of frames); dropped keypoints (`DROP_RATE`) and
joints outside the picture missing, filled over time as the lifter fills them.
"""

from __future__ import annotations

from dataclasses import dataclass

import kornia.geometry as kg
import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d

from gesturebank.config import FittedConfig
from gesturebank.lift.learned import features as F
from gesturebank.lift.scoring import MIRROR
from gesturebank.mocap.pose import body_axes

# BlazePose's 2D error against the projected truth on the project's renders of test.bvh 21–31 s
# (a tuning stretch) at 0/30/60°, in neck → mid-hip lengths, per joint (nose … right_hip): the
# mean offset along the image's y (down; the shoulders sit high) and the standard deviation about
# it (x and y averaged). The error drifts slowly (lag-1 autocorrelation 0.98 at 30 fps).
NOISE_BIAS_Y = (-0.010, -0.004, -0.027, 0.047, -0.011, -0.073, -0.037, -0.041, 0.029, -0.005,
                0.016, 0.041, 0.032)  # fmt: skip
NOISE_SD = (0.048, 0.040, 0.050, 0.038, 0.034, 0.057, 0.059, 0.060, 0.083, 0.040, 0.063, 0.042,
            0.038)  # fmt: skip
NOISE_SMOOTH_FRAMES = 4.0  # σ of the Gaussian that makes the white noise drift
BLUR_SHARE = 0.3  # extra error per spine length a joint moves in a frame (motion blur; assumed)
OUTSIDE_SD = 0.15  # extra error of a joint outside the picture (a guess, spine lengths)
SWAP_RATE = 0.013  # share of frames with left and right exchanged (issue 39's measurement)
DROP_RATE = 0.02  # share of a face or arm keypoint's frames missing (assumed)
MIN_DEPTH_M = 0.5  # nearer than this to a camera, a person is not seen whole
_SIDES = [(1, 2), (3, 4), (5, 6), (7, 8), (9, 10), (11, 12)]  # left/right pairs of the 13
_TORSO = [5, 6, 11, 12]
_MIRROR13 = np.asarray(MIRROR[: F.N_JOINTS])


@dataclass(frozen=True)
class CameraRanges:
    """Ranges of the random training cameras (metres for a person of neck → mid-hip 0.5 m)."""

    front_share: float = 0.8  # the rest anywhere around the person
    front_deg: float = 90.0  # azimuth ± this many degrees from the person's front
    height_m: tuple[float, float] = (-0.5, 1.2)  # above the chest
    distance_m: tuple[float, float] = (1.2, 6.0)  # log-uniform
    fov_deg: tuple[float, float] = (35.0, 100.0)  # across the image's width
    portrait_share: float = 0.2  # a phone held upright
    roll_sd_deg: float = 3.0
    distorted_share: float = 0.3  # with barrel distortion k1 in `k1`
    k1: tuple[float, float] = (-0.25, 0.02)
    calibrated_share: float = 0.5  # read with the true camera, else with `[fitted] fov_deg`
    tries: int = 4  # candidate cameras per stretch


def _look_at(eye: torch.Tensor, target: torch.Tensor, up: torch.Tensor) -> torch.Tensor:
    """(B, 3, 3) world → camera rotations (x right, y down, z forward) of look-at cameras."""
    forward = torch.nn.functional.normalize(target - eye, dim=-1)
    down = -(up - (up * forward).sum(-1, keepdim=True) * forward)
    down = torch.nn.functional.normalize(down, dim=-1)
    return torch.stack([torch.cross(down, forward, dim=-1), down, forward], dim=1)


def _axes(joints: np.ndarray, up: np.ndarray | None) -> np.ndarray:
    """(3, 3) the person's mean forward, left and up; with the world's `up` given, forward and
    left level (a leaning person is seen leaning), else the torso's own (body_axes)."""
    fwd, left, torso_up = body_axes(joints)
    if up is None:
        return np.stack([fwd, left, torso_up])
    fwd = fwd - (fwd @ up) * up
    fwd /= np.linalg.norm(fwd)
    return np.stack([fwd, np.cross(up, fwd), up])


def view_batch(
    joints: list[np.ndarray], ups: list[np.ndarray | None], *, rng: np.random.Generator,
    cams: CameraRanges,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """For world joints (T, 17, 3) per stretch and its world's up (None: the torso's): ray
    coordinates uv (B, T, 13, 2) as the lifter reads them, camera-frame joints (B, T, 13, 3),
    which joints lie outside the picture (B, T, 13), and which stretches a candidate camera
    saw (B,) (the others' views are not to be used)."""
    b, n = len(joints), cams.tries
    world = torch.from_numpy(np.stack(joints)[:, :, : F.N_JOINTS]).double()  # (B, T, 13, 3)
    axes = np.stack([_axes(j, up) for j, up in zip(joints, ups, strict=True)])  # (B, 3, 3)
    neck = np.stack([j[:, 5:7].mean(1) for j in joints])
    hips = np.stack([j[:, 11:13].mean(1) for j in joints])
    chest = (0.75 * neck + 0.25 * hips).mean(1)  # (B, 3)
    scale = np.median(np.linalg.norm(neck - hips, axis=-1), axis=1) / 0.5  # (B,)

    def draw(lo: float, hi: float) -> np.ndarray:
        return rng.uniform(lo, hi, (n, b))

    around = rng.random((n, b)) < cams.front_share
    azimuth = np.where(around, np.deg2rad(draw(-cams.front_deg, cams.front_deg)),
                       draw(-np.pi, np.pi))  # fmt: skip
    dist = np.exp(draw(*np.log(cams.distance_m))) * scale
    height = draw(*cams.height_m) * scale
    fwd, left, up = (axes[None, :, k] for k in range(3))
    toward = np.cos(azimuth)[..., None] * fwd + np.sin(azimuth)[..., None] * left
    eye = chest + dist[..., None] * toward + height[..., None] * up
    portrait = rng.random((n, b)) < cams.portrait_share
    size = np.where(portrait[..., None], [720.0, 1280.0], [1280.0, 720.0])  # (n, B, 2)
    focal = 0.5 * size[..., 0] / np.tan(np.deg2rad(draw(*cams.fov_deg)) / 2)
    # aim so the chest lands anywhere in the picture: turn the camera by the angles to that pixel
    where = rng.uniform(0.15, 0.85, (n, b, 2)) * size - size / 2
    turn = np.stack([np.arctan2(where[..., 1], focal), -np.arctan2(where[..., 0], focal),
                     np.deg2rad(rng.normal(0.0, cams.roll_sd_deg, (n, b)))], -1)  # fmt: skip
    flat = lambda a: torch.from_numpy(np.ascontiguousarray(a.reshape(n * b, *a.shape[2:])))  # noqa: E731
    rot = kg.conversions.axis_angle_to_rotation_matrix(flat(turn)) @ _look_at(
        flat(eye),
        torch.from_numpy(np.array(np.broadcast_to(chest, (n, b, 3)).reshape(-1, 3))),
        flat(np.broadcast_to(up, (n, b, 3))),
    )
    w = world.repeat(n, 1, 1, 1)  # (n·B, T, 13, 3), candidate-major like `flat`
    local = torch.einsum("bij,btkj->btki", rot, w - flat(eye)[:, None, None])
    K = torch.zeros(n * b, 3, 3, dtype=torch.float64)
    K[:, 0, 0] = K[:, 1, 1] = flat(focal)
    K[:, :2, 2] = flat(size) / 2
    K[:, 2, 2] = 1.0
    t = local.shape[1]
    pts = local.reshape(n * b, -1, 3)
    safe = torch.where(pts[..., 2:] > 1e-3, pts, torch.full_like(pts, 1.0))
    pixels = kg.camera.perspective.project_points(safe, K[:, None])
    dist_k = np.zeros((n, b, 4))
    dist_k[..., 0] = np.where(rng.random((n, b)) < cams.distorted_share, draw(*cams.k1), 0.0)
    seen_px = kg.calibration.distort_points(pixels, K, flat(dist_k))
    calibrated = flat(rng.random((n, b)) < cams.calibrated_share)
    half_fov = np.deg2rad(FittedConfig().fov_deg) / 2
    assumed = 0.5 * torch.max(flat(size), -1).values / np.tan(half_fov)
    uv_cal = (pixels - K[:, None, :2, 2]) / K[:, None, 0, :1]
    uv_raw = (seen_px - K[:, None, :2, 2]) / assumed[:, None, None]
    uv = torch.where(calibrated[:, None, None], uv_cal, uv_raw).reshape(n * b, t, F.N_JOINTS, 2)
    px = seen_px.reshape(n * b, t, F.N_JOINTS, 2)
    sz = flat(size)[:, None, None]
    outside = ((px < 0) | (px > sz)).any(-1)
    margin = 0.05 * sz
    shoulders_in = ((px[:, :, 5:7] > -margin) & (px[:, :, 5:7] < sz + margin)).all(dim=(1, 2, 3))
    hips_near = ((px[:, :, 11:13] > -0.3 * sz) & (px[:, :, 11:13] < 1.3 * sz)).all(dim=(1, 2, 3))
    near = local[..., 2] > MIN_DEPTH_M * flat(np.broadcast_to(scale, (n, b)))[:, None, None]
    ok = (shoulders_in & hips_near & near.all(dim=(1, 2))).reshape(n, b).numpy()
    pick = np.where(ok.any(0), ok.argmax(0), 0) * b + np.arange(b)
    return uv[pick].numpy(), local[pick].numpy(), outside[pick].numpy(), np.asarray(ok.any(0))


def _runs(rng: np.random.Generator, frames: int, rate: float, longest: int) -> np.ndarray:
    """(frames,) bool: runs of 1…`longest` frames covering about `rate` of them."""
    on = np.zeros(frames, bool)
    starts = rng.random(frames) < rate * 2 / (1 + longest)
    for s in np.flatnonzero(starts):
        on[s : s + int(rng.integers(1, longest + 1))] = True
    return on


def detector_noise(
    uv: np.ndarray, local: np.ndarray, *, outside: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """Ray coordinates uv (T, 13, 2) of one stretch as a detector gives them (module doc), NaN
    where a keypoint is missing; `local` (T, 13, 3) the camera-frame joints, `outside` (T, 13)."""
    frames = len(uv)
    spine = np.linalg.norm(uv[:, 5:7].mean(1) - uv[:, 11:13].mean(1), axis=-1)[:, None, None]
    shape = (frames, F.N_JOINTS, 2)
    drift = gaussian_filter1d(rng.normal(size=shape), NOISE_SMOOTH_FRAMES, axis=0)
    drift /= drift.std(axis=0, keepdims=True) + 1e-9
    level = rng.uniform(0.5, 1.5)
    noise = drift * np.asarray(NOISE_SD)[None, :, None] * level + rng.normal(0.0, 0.01, shape)
    bias = np.stack([rng.normal(0.0, 0.03, F.N_JOINTS),
                     np.asarray(NOISE_BIAS_Y) * rng.uniform(0.0, 1.5)], -1)  # fmt: skip
    speed = np.linalg.norm(np.gradient(uv, axis=0), axis=-1) / spine[..., 0]  # spines / frame
    noise += rng.normal(size=shape) * (BLUR_SHARE * rng.uniform(0.0, 2.0) * speed)[..., None]
    noise += rng.normal(size=shape) * OUTSIDE_SD * outside[..., None]
    out = uv + spine * (noise + bias[None])
    if rng.random() < 0.5:  # exchanged sides: the whole body, or one pair
        swap = _runs(rng, frames, SWAP_RATE * rng.uniform(0.0, 3.0), 6)
        if rng.random() < 0.5:
            out[swap] = out[swap][:, _MIRROR13]
        else:
            a, b = _SIDES[int(rng.integers(len(_SIDES)))]
            out[swap, a], out[swap, b] = out[swap, b], out[swap, a].copy()
    for j in range(F.N_JOINTS):
        if j in _TORSO:
            continue
        gone = _runs(rng, frames, DROP_RATE * rng.uniform(0.0, 2.0), 8)
        if rng.random() < 0.5:
            gone |= outside[:, j]
        out[gone, j] = np.nan
    return out
