"""`gesturebank calibrate`: camera intrinsics from photos of a board."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import typer

from gesturebank.cli.options import ConfigOption, SetOption, resolve_config
from gesturebank.cli.terminal import out, user_errors


def calibrate(
    photos: Annotated[
        Path,
        typer.Argument(help="Folder with one sub-folder of board photos per camera."),
    ],
    *,
    placement: Annotated[
        Path,
        typer.Option(
            "--placement", help="Calibration (.toml, .qca.txt) whose camera positions are kept."
        ),
    ],
    out_file: Annotated[Path, typer.Option("--out", help="Calibration TOML to write.")],
    kind: Annotated[Literal["checkerboard", "charuco"] | None, typer.Option("--board")] = None,
    inner_corners: Annotated[
        tuple[int, int] | None, typer.Option(help="Checkerboard: inner corners x y.")
    ] = None,
    squares: Annotated[tuple[int, int] | None, typer.Option(help="ChArUco: squares x y.")] = None,
    square_size: Annotated[float | None, typer.Option(help="Square side, metres.")] = None,
    config_file: ConfigOption = None,
    sets: SetOption = None,
) -> None:
    """Calibrate each camera's intrinsics from photos of a board; write the TOML `multiview` reads.

    PHOTOS holds one sub-folder per camera (Pose2Sim's `int_cam01_img` is camera `cam01`, the
    stem of its video). Rotation and translation come from --placement; the board is the [board]
    section (--set board.KEY=VALUE; the flags win), by default Pose2Sim's 4 x 7 inner-corner,
    6 cm checkerboard.
    """
    from gesturebank.camera_files import cameras_toml, load_cameras
    from gesturebank.fileio import output_errors, write_bytes_atomic
    from gesturebank.lift.multiview.calibrate import calibrate_group

    board: dict[str, Any] = dict(
        kind=kind, inner_corners=inner_corners, squares=squares, square_size=square_size
    )
    with user_errors():
        config = resolve_config(config_file=config_file, sets=sets, flags={"board": board})
        group, reports = calibrate_group(
            photos=photos, placement=load_cameras(placement), board=config.board
        )
        with output_errors(out_file, "the calibration"):
            write_bytes_atomic(out_file, cameras_toml(group).encode())
    for name, r in reports.items():
        out.print(
            f"{name}: board in {len(r.per_image)} of "
            f"{len(r.per_image) + len(r.rejected) + len(r.missing)} photos, "
            f"rms {r.rms:.2f} px, focal {r.focal:.1f} px",
            highlight=False,
        )
    out.print(f"calibration: {out_file}", highlight=False, soft_wrap=True)
