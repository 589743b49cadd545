"""Frames of figures seen by one camera: Embree ray casting (open3d's `RaycastingScene`) of the
figures' meshes, then Lambert shading, the look's colours and the face photo.

One ray per (sub)pixel; the nearest hit gives depth, the part (the mesh's geometry id) and the
triangle's normal. Colours come from the part's role; an arm's sleeve ends where the shirt
ends along the bone, and the head's front is the face photo (module `looks`), looked up by the
hit point's position in the head's own axes, so it turns with the head.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np

from gesturebank.camera_files import Camera
from gesturebank.errors import GesturebankError
from gesturebank.skeletons import COCO17
from gesturebank.synth.camera import pixel_rays
from gesturebank.synth.figure import PART_INDEX, PARTS, Mesh, figure_meshes, head_frame
from gesturebank.synth.looks import Look, background, face_colours

AMBIENT, DIFFUSE = 0.4, 0.6
# Towards the light, in camera axes (x right, y down, z forward): above, left of and behind the
# camera, so the figure is lit from the front with soft shading on its sides.
LIGHT_CAMERA = (-0.35, -0.6, -1.0)
MISS = -1  # part id of a ray that hits nothing


@dataclass(frozen=True)
class Figure:
    """One person in the scene.

    joints: (T, 17, 3) COCO-17 world metres, all finite; mouth: (T,) opening in [0, 1] (0 =
    closed); look: its clothing, skin and hair.
    """

    joints: np.ndarray
    mouth: np.ndarray
    look: Look
    meshes: list[Mesh] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        joints = np.asarray(self.joints, np.float64)
        mouth = np.asarray(self.mouth, np.float64)
        if joints.ndim != 3 or joints.shape[1:] != (len(COCO17), 3):
            raise ValueError(f"Figure: joints must be (T, 17, 3), got {joints.shape}")
        if not np.isfinite(joints).all():
            raise ValueError("Figure: joints must all be finite")
        if mouth.shape != (len(joints),):
            raise ValueError(f"Figure: mouth must be ({len(joints)},), got {mouth.shape}")
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "mouth", mouth)
        object.__setattr__(self, "meshes", figure_meshes(joints))


@dataclass(frozen=True)
class Hits:
    """What the rays of one frame hit inside `box` = (x0, y0, x1, y1) (sub)pixels, the figures'
    bounding box (rays outside it hit nothing), (h, w) each: depth along the ray (inf:
    nothing), part id (`figure · len(PARTS) + part index`, MISS: nothing); and for the rays
    that hit, in the order of `part != MISS`, world hit points and unit normals facing the
    camera (N, 3)."""

    box: tuple[int, int, int, int]
    depth: np.ndarray
    part: np.ndarray
    points: np.ndarray
    normals: np.ndarray


def _box(figures: Sequence[Figure], frame: int, camera: Camera, scale: int) -> tuple[int, ...]:
    """The figures' bounding box in the (sub)pixel grid, a pixel wider on each side; the whole
    image when a vertex is behind the camera."""
    w, h = camera.size[0] * scale, camera.size[1] * scale
    vertices = np.concatenate([m.vertices[frame] for f in figures for m in f.meshes])
    px = camera.project(vertices)
    if not np.isfinite(px).all():
        return (0, 0, w, h)
    px = (px + 0.5) * scale - 0.5
    x0, y0 = np.floor(px.min(axis=0)).astype(int) - 1
    x1, y1 = np.ceil(px.max(axis=0)).astype(int) + 2
    return (
        int(np.clip(x0, 0, w)),
        int(np.clip(y0, 0, h)),
        int(np.clip(x1, 0, w)),
        int(np.clip(y1, 0, h)),
    )


def cast(figures: Sequence[Figure], frame: int, *, rays: np.ndarray, box: tuple[int, ...]) -> Hits:
    """Cast the `rays` (H, W, 6) inside `box` at the figures' meshes as they are at `frame`."""
    try:
        import open3d as o3d
    except ImportError:
        raise GesturebankError(
            "rendering needs open3d: pip install 'gesturebank[multiview]' (and libusb-1.0-0)"
        ) from None

    x0, y0, x1, y1 = box
    rays = np.ascontiguousarray(rays[y0:y1, x0:x1])
    scene = o3d.t.geometry.RaycastingScene()
    for figure in figures:
        for mesh in figure.meshes:
            scene.add_triangles(
                o3d.core.Tensor.from_numpy(np.ascontiguousarray(mesh.vertices[frame])),
                o3d.core.Tensor.from_numpy(mesh.triangles),
            )
    answer = scene.cast_rays(o3d.core.Tensor.from_numpy(rays))
    depth = answer["t_hit"].numpy()
    ids = answer["geometry_ids"].numpy().astype(np.int64)
    hit = np.isfinite(depth)
    part = np.where(hit, ids, MISS)
    direction = rays[hit][:, 3:]
    points = rays[hit][:, :3] + direction * depth[hit][:, None]
    normals = answer["primitive_normals"].numpy()[hit]
    facing = np.sum(normals * direction, axis=-1) > 0
    normals[facing] *= -1
    return Hits(box=(x0, y0, x1, y1), depth=depth, part=part, points=points, normals=normals)


def _sleeve(points: np.ndarray, start: np.ndarray, end: np.ndarray, share: float) -> np.ndarray:
    """(N,) whether hit points lie on the first `share` of the bone start → end."""
    bone = end - start
    along = (points - start) @ bone / max(float(bone @ bone), 1e-12)
    return along < share


def colours(figures: Sequence[Figure], frame: int, *, hits: Hits) -> np.ndarray:
    """(N, 3) float32 unshaded colours of the hit rays, in the order of `hits.part >= 0`."""
    part = hits.part[hits.part != MISS]
    points = hits.points
    out = np.zeros((len(part), 3), np.float32)
    n = len(PARTS)
    for f, figure in enumerate(figures):
        look = figure.look
        roles = {
            "skin": look.skin,
            "hair": look.hair,
            "shirt": look.shirt,
            "trousers": look.trousers,
            "shoes": look.shoes,
            "face": look.skin,
            "upper_sleeve": look.skin,
            "lower_sleeve": look.skin,
        }
        mine = (part >= f * n) & (part < (f + 1) * n)
        local = part[mine] - f * n
        table = np.array([roles[role] for _, role in PARTS], np.float32)
        colour = table[local]
        p = points[mine]
        j = figure.joints[frame]
        for side in ("left", "right"):
            for bone, a, b, share in (
                ("upper_arm", "shoulder", "elbow", look.upper_sleeve),
                ("forearm", "elbow", "wrist", look.lower_sleeve),
            ):
                on = local == PART_INDEX[f"{side}_{bone}"]
                if share > 0 and on.any():
                    start, end = j[COCO17.index[f"{side}_{a}"]], j[COCO17.index[f"{side}_{b}"]]
                    shirt = _sleeve(p[on], start, end, share)
                    colour[np.flatnonzero(on)[shirt]] = look.shirt
        on_head = (local == PART_INDEX["head"]) | (local == PART_INDEX["nose"])
        if on_head.any():
            centre, axes = head_frame(j[None])
            rel = p[on_head] - centre[0]
            forward, up, left = axes[0] @ rel.T
            face = face_colours(left, up, look=look, mouth=np.full(len(rel), figure.mouth[frame]))
            front = np.clip(forward / 0.03, 0, 1)[:, None]  # the photo on the front half only
            colour[on_head] = front * face + (1 - front) * np.asarray(look.skin, np.float32)
        out[mine] = colour
    return out


def render_frames(
    figures: Sequence[Figure], camera: Camera, *, scenery: Look, supersample: int
) -> Iterator[np.ndarray]:
    """(H, W, 3) uint8 RGB frames, one per frame of the figures (all of one length), seen by
    `camera` in front of `scenery`'s background; `supersample`² rays per pixel, averaged."""
    from skimage.transform import downscale_local_mean

    w, h = camera.size
    s = supersample
    rays = pixel_rays(camera, supersample=s)
    wall = background(scenery, size=(w * s, h * s))
    light = camera.R.T @ np.asarray(LIGHT_CAMERA)
    light /= np.linalg.norm(light)
    for frame in range(len(figures[0].joints)):
        hits = cast(figures, frame, rays=rays, box=_box(figures, frame, camera, s))
        hit = hits.part != MISS
        lambert = AMBIENT + DIFFUSE * np.clip(hits.normals @ light, 0, 1)
        image = wall.copy()
        x0, y0, x1, y1 = hits.box
        image[y0:y1, x0:x1][hit] = colours(figures, frame, hits=hits) * lambert[:, None]
        if s > 1:
            image = downscale_local_mean(image, (s, s, 1))
        yield np.clip(image * 255 + 0.5, 0, 255).astype(np.uint8)
