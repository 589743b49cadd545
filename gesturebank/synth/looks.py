"""How a figure looks: clothing, skin, hair and background colours, the face photo, and how far
the sleeves reach. Two looks ship (`LOOKS`): a T-shirt on a light wall, long sleeves on a brick
wall with a darker skin."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np

# The face photo: scikit-image's astronaut (Eileen Collins, NASA, public domain). Its eyes are
# at (203, 101) and (247, 101) px and its mouth at (225, 147) px of the 512 × 512 image.
PHOTO_EYES_MID = (225.0, 101.0)
PHOTO_EYE_DISTANCE_PX = 44.0
PHOTO_MOUTH = (225.0, 147.0)
PHOTO_FACE_BOX = (172, 42, 278, 192)  # x0, y0, x1, y1: forehead to chin, cheek to cheek
PHOTO_SKIN = (0.86, 0.66, 0.56)  # mean colour of its cheeks
# The drawn mouth (module docstring of `face_colours`), metres on the face: an adult's mouth is
# about 50 mm wide, its lips 6-9 mm high, and it opens about 25 mm when speaking loudly.
MOUTH_HALF_WIDTH_M = 0.025
LIP_HEIGHTS_M = (0.006, 0.008)  # upper, lower, in the middle
LIP_LINE_M = 0.0015  # the dark line where shut lips meet
MOUTH_MAX_GAP_M = 0.024  # between the lips at opening 1
MOUTH_GAP_UP = 0.3  # share of the opening the upper lip rises (the jaw drops the rest)
SKIN_PATCH_M = (0.036, 0.017)  # half width, half height of the skin over the photo's smile
LIP_COLOUR = (0.76, 0.5, 0.46)  # on the photo's skin; tinted with the look's skin
LIP_LINE_COLOUR = (0.5, 0.3, 0.28)
INNER_MOUTH = (0.12, 0.03, 0.03)


@dataclass(frozen=True)
class Look:
    """Colours are RGB in [0, 1].

    upper_sleeve, lower_sleeve: share of the upper arm / forearm (from the shoulder / elbow)
    the shirt covers; the rest is skin.
    background: "plain" (a vertical gradient of `wall`) or "brick" (scikit-image's brick
    texture tinted with `wall`).
    """

    skin: tuple[float, float, float]
    hair: tuple[float, float, float]
    shirt: tuple[float, float, float]
    trousers: tuple[float, float, float]
    shoes: tuple[float, float, float]
    wall: tuple[float, float, float]
    upper_sleeve: float
    lower_sleeve: float
    background: str


LOOKS = {
    "tshirt": Look(
        skin=PHOTO_SKIN,
        hair=(0.45, 0.3, 0.15),
        shirt=(0.15, 0.35, 0.7),
        trousers=(0.2, 0.2, 0.25),
        shoes=(0.1, 0.08, 0.06),
        wall=(0.85, 0.84, 0.8),
        upper_sleeve=0.45,
        lower_sleeve=0.0,
        background="plain",
    ),
    "sleeves": Look(
        skin=(0.55, 0.38, 0.27),
        hair=(0.08, 0.06, 0.05),
        shirt=(0.75, 0.2, 0.15),
        trousers=(0.55, 0.5, 0.4),
        shoes=(0.25, 0.2, 0.18),
        wall=(0.75, 0.72, 0.68),
        upper_sleeve=1.0,
        lower_sleeve=0.95,
        background="brick",
    ),
}


def background(look: Look, *, size: tuple[int, int]) -> np.ndarray:
    """(H, W, 3) float32 background image of `look` at `size` = (width, height)."""
    w, h = size
    wall = np.asarray(look.wall, np.float32)
    if look.background == "brick":
        from skimage import data, transform

        brick = data.brick().T.astype(np.float32) / 255  # grey, 512 × 512; rows of bricks
        scale = max(h, w) / 1024  # about two tiles across a 1280 px frame
        tile = transform.rescale(brick, max(scale, 0.1), anti_aliasing=True)
        reps = (-(-h // tile.shape[0]), -(-w // tile.shape[1]))
        shade = np.tile(tile, reps)[:h, :w]
        shade = 0.75 + 0.5 * (shade - shade.mean())
        return np.clip(shade[..., None] * wall, 0, 1).astype(np.float32)
    gradient = np.linspace(1.05, 0.85, h, dtype=np.float32)[:, None, None]
    return np.clip(np.broadcast_to(gradient * wall, (h, w, 3)), 0, 1).astype(np.float32)


@cache
def face_photo() -> np.ndarray:
    """(512, 512, 3) float32 in [0, 1]: the face photo."""
    from skimage import data

    return data.astronaut().astype(np.float32) / 255


def face_colours(left: np.ndarray, up: np.ndarray, *, look: Look, mouth: np.ndarray) -> np.ndarray:
    """(N, 3) colours of head points at `left`, `up` (N,) metres from the eyes' midpoint in the
    head's axes (seen from the front), the photo faded into the look's skin outside the face
    (hair above the brows) and tinted to it; `mouth` (N,) in [0, 1] opens the drawn mouth
    (0: shut lips, `_paint_mouth`)."""
    photo = face_photo()
    px_per_m = PHOTO_EYE_DISTANCE_PX / 0.064  # the face model's eyes are 64 mm apart
    x = PHOTO_EYES_MID[0] + left * px_per_m
    y = PHOTO_EYES_MID[1] - up * px_per_m
    x0, y0, x1, y1 = PHOTO_FACE_BOX
    # Elliptic fade: 1 inside the face box's inscribed ellipse, 0 a little outside it.
    cx, cy, rx, ry = (x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2
    r = np.sqrt(((x - cx) / rx) ** 2 + ((y - cy) / ry) ** 2)
    weight = np.clip((1.15 - r) / 0.2, 0, 1)[:, None]
    xi = np.clip(np.round(x).astype(int), 0, photo.shape[1] - 1)
    yi = np.clip(np.round(y).astype(int), 0, photo.shape[0] - 1)
    tint = np.asarray(look.skin, np.float32) / np.asarray(PHOTO_SKIN, np.float32)
    face = np.clip(photo[yi, xi] * tint, 0, 1)
    # Around the photo: hair above the brows, skin below.
    around = np.where(
        (up > 0.035)[:, None], np.asarray(look.hair, np.float32), np.asarray(look.skin, np.float32)
    )
    colour = weight * face + (1 - weight) * around
    mx = (PHOTO_MOUTH[0] - PHOTO_EYES_MID[0]) / px_per_m
    my = (PHOTO_EYES_MID[1] - PHOTO_MOUTH[1]) / px_per_m
    return _paint_mouth(colour, left - mx, up - my, tint=tint, look=look, opening=mouth)


def _paint_mouth(
    colour: np.ndarray,
    across: np.ndarray,
    along_up: np.ndarray,
    *,
    tint: np.ndarray,
    look: Look,
    opening: np.ndarray,
) -> np.ndarray:
    """`colour (N, 3)` with the drawn mouth over the photo's: points at `across`, `along_up`
    (N,) metres from the photo's mouth centre. The photo smiles with its teeth showing, which a
    face landmark model reads as open (0.078 of the face's height, more than its drawn-open
    ellipse); so its lips are covered with skin and closed lips are drawn, which part with
    `opening (N,)` in [0, 1] around a dark inner mouth, the jaw taking most of it."""
    gap = MOUTH_MAX_GAP_M * np.clip(opening, 0, 1)
    u = across / MOUTH_HALF_WIDTH_M
    shape = np.sqrt(np.clip(1 - u * u, 0, 1))  # lips part most in the middle, not at the corners
    top = MOUTH_GAP_UP * gap * shape
    bottom = -(1 - MOUTH_GAP_UP) * gap * shape
    # skin over the photo's lips and teeth (an ellipse reaching below the dropped lower lip)
    below = SKIN_PATCH_M[1] + (1 - MOUTH_GAP_UP) * gap
    half_height = np.where(along_up >= 0, SKIN_PATCH_M[1], below)
    r = np.hypot(across / SKIN_PATCH_M[0], along_up / half_height)
    weight = np.clip((1.1 - r) / 0.2, 0, 1)[:, None]
    colour = weight * np.asarray(look.skin, np.float32) + (1 - weight) * colour
    taper = 0.4 + 0.6 * shape  # lips thinner towards the corners
    inside = np.abs(u) < 1
    upper = inside & (along_up >= top) & (along_up < top + LIP_HEIGHTS_M[0] * taper)
    lower = inside & (along_up < bottom) & (along_up >= bottom - LIP_HEIGHTS_M[1] * taper)
    colour[upper | lower] = np.clip(np.asarray(LIP_COLOUR, np.float32) * tint, 0, 1)
    # between the lips: a line where they meet, the dark inner mouth where they part
    meet = inside & (np.abs(along_up - (top + bottom) / 2) < LIP_LINE_M / 2)
    parted = inside & (along_up < top) & (along_up >= bottom)
    colour[meet] = np.clip(np.asarray(LIP_LINE_COLOUR, np.float32) * tint, 0, 1)
    colour[parted] = INNER_MOUTH
    return colour.astype(np.float32)
