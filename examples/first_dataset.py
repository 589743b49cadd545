"""A first look at a gesturebank dataset through the Python API, in four steps:

1. open the dataset folder (written by `gesturebank build-dataset`) and list its clips;
2. plot one clip's Pepper angles above its audio features, on the clip's 100 Hz clock;
3. train a small model on that clip's speaker (the subject-dependent split), for a few epochs;
4. synthesise angles for a speech file with it, as the CSV that `gesturebank replay` plays.

    python examples/first_dataset.py DATASET_DIR OUT_DIR [--speech FILE] [--epochs N]

OUT_DIR gets clip.png, model/ and angles.csv. Without --speech the speech is the clip's own
source video (any file with an audio track will do). The model is the dissertation's MLP with a
handful of epochs: enough to see the pipeline run, far too few for a model worth watching
(`gesturebank train` uses up to 10,000).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no window: runs on a server or in CI
import matplotlib.pyplot as plt
import numpy as np

from gesturebank import datasets
from gesturebank.cli.training import train_command
from gesturebank.config import TrainConfig
from gesturebank.train.synthesis import synthesize


def plot_clip(dataset: datasets.Dataset, clip_id: str, out: Path) -> Path:
    """The clip's 11 angles (degrees; gaps where a limb was unseen) above its audio features."""
    clip = dataset.load(clip_id)
    kind = dataset.info.audio_features.kind
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    for j, name in enumerate(dataset.info.joints):
        top.plot(clip.times, np.degrees(clip.angles[:, j]), lw=1, label=name)
    top.set_ylabel("angle (°)")
    top.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    top.set_title(f"{clip_id}: Pepper's angles and the speech's {kind} features")
    extent = (clip.times[0], clip.times[-1], 0, clip.audio.shape[1])
    bottom.imshow(clip.audio.T, aspect="auto", origin="lower", extent=extent, cmap="magma")
    bottom.set_ylabel(f"{kind} feature")
    bottom.set_xlabel("clip time (s)")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a dataset folder written by build-dataset")
    parser.add_argument("out", type=Path, help="folder for clip.png, model/ and angles.csv")
    parser.add_argument(
        "--speech", type=Path, help="speech to synthesise for (default: the clip's video)"
    )
    parser.add_argument("--epochs", type=int, default=2, help="training epochs (default 2)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    # 1. open: a lazy reader; the manifest rows say what each clip is
    ds = datasets.open(args.dataset)
    rows = ds.clips("accepted") or ds.clips(None)
    print(f"{ds.path}: {len(ds)} clips, {ds.info.usable_s:.1f} s accepted")
    for row in rows:
        print(f"  {row.clip.clip_id}  subject {row.take.subject}  {row.clip.duration_s:.1f} s")
    row = rows[0]

    # 2. plot one clip
    png = plot_clip(ds, row.clip.clip_id, args.out / "clip.png")
    print(f"plot: {png}")

    # 3. train on the speaker's own recordings (subject-dependent split), a few epochs
    config = TrainConfig.model_validate({"mlp": {"max_epochs": args.epochs}})
    model_dir = args.out / "model"
    result = train_command(
        args.dataset, model="mlp", variant="sd", subject=row.take.subject, out_dir=model_dir,
        config=config, quiet=True,
    )  # fmt: skip
    best = f"best validation loss {result.best_val_loss:.4f}"
    print(f"model: {model_dir} ({result.epochs} epochs, {best})")

    # 4. synthesise: speech → 11 angles at 100 Hz, normalised with the speaker's audio stats
    speech = args.speech or Path(ds.info.videos_dir) / row.take.source
    angles = synthesize(
        model_dir, audio_path=speech, out_csv=args.out / "angles.csv", znorm=row.take.subject
    )
    print(f"angles: {args.out / 'angles.csv'} ({len(angles)} frames for {speech.name})")


if __name__ == "__main__":
    main()
