"""Bring a dataset folder's shared files up to date with its take records: the QC verdicts over
every clip (dataset-relative ones need them all), manifest.parquet, dataset.json (audio
normalisation stats, per-take summary), the dataset card DATASET.md (`datasets.card`) and the
splits. `build-dataset` calls it after the takes are built, `gesturebank qc` after changing
thresholds; the QC itself stays pure over metrics.

Metrics are measured by the workers as each take is built; only clips whose metrics were
measured with other measuring settings (`qc.analysis_rate_hz`, …) are loaded and measured again.
"""

from __future__ import annotations

import itertools
import json
import logging
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from gesturebank import __version__
from gesturebank.config import Config, QCConfig
from gesturebank.datasets import store
from gesturebank.datasets.card import read_takes_toml, write_card
from gesturebank.datasets.digest import content_digest, measure_digest
from gesturebank.datasets.judging import judged_records, write_clip
from gesturebank.datasets.partners import pair_clips
from gesturebank.datasets.splits import write_splits
from gesturebank.errors import InputError
from gesturebank.qc.checks import failures, verdicts
from gesturebank.qc.clip_metrics import ClipMetrics
from gesturebank.qc.metrics import clip_metrics
from gesturebank.robot import pepper

log = logging.getLogger(__name__)


def _remeasure(
    out: Path, record: store.TakeRecord, *, qc: QCConfig, profile: str, recheck: bool = False
) -> store.TakeRecord:
    """The record with every clip measured with the current settings (`recheck`: every clip
    measured again from its arrays, so the invariants of `qc.invariants` are applied to what
    the folder holds now)."""
    digest = measure_digest(qc=qc, profile=profile)
    if not recheck and all(c.measured == digest for c in record.data_clips):
        return record
    robot = pepper.load_profile(profile)
    clips = []
    for c in record.clips:
        if c.kind == "clip" and (recheck or c.measured != digest):
            clip = store.read_clip(store.clip_npz(out, take_id=record.take_id, clip_id=c.clip_id))
            # metrics of the whole take (trimmed_fraction) are not in the clip: kept as measured
            metrics = {**c.metrics, **clip_metrics(clip, profile=robot, qc=qc).to_dict()}
            c = replace(c, metrics=metrics, measured=digest)
        clips.append(c)
    return store.with_clips(record, clips)


def _cut(
    out: Path, record: store.TakeRecord, *, qc: QCConfig, min_s: float, profile: str
) -> store.TakeRecord:
    """The record with every clip that fails stretch checks only cut around the failing
    stretches (`datasets.judging`, as the build does): its pieces written beside it, its file
    removed, a span for each stretch cut out. Loosening the thresholds later does not join the
    pieces again; rebuilding the take does."""
    robot = pepper.load_profile(profile)
    rows: list[store.ClipRecord] = []
    changed = False
    for c in record.clips:
        failed = [] if c.kind != "clip" else failures(ClipMetrics.from_dict(c.metrics), qc)
        if not failed or any(f.scope == "take" for f in failed) or qc.stretch_rounds <= 0:
            rows.append(c)
            continue
        path = store.clip_npz(out, take_id=record.take_id, clip_id=c.clip_id)
        clip = store.read_clip(path)
        trimmed = c.metrics.get("trimmed_fraction")
        kept, judged = judged_records(
            clip,
            qc=qc,
            min_s=min_s,
            profile=robot,
            measured=c.measured,
            trimmed=None if trimmed is None else float(trimmed),
            clip_ids=(f"{c.clip_id}p{k}" for k in itertools.count()),
            span_ids=(f"{c.clip_id}s{k}" for k in itertools.count()),
            keep_id=True,
        )
        if len(judged) == 1:  # not cut: rejected whole, as judged below
            rows.append(c)
            continue
        for piece in kept:
            write_clip(store.clip_npz(out, take_id=record.take_id, clip_id=piece.clip_id), piece)
        path.unlink()
        rows += judged
        changed = True
    if not changed:
        return record
    return _repaired_partners(out, store.with_clips(record, sorted(rows, key=lambda r: r.start_s)))


def _repaired_partners(out: Path, record: store.TakeRecord) -> store.TakeRecord:
    """After cutting, a partner may name a clip that was cut (its file gone, its pieces
    renamed): the take's clips of several people are paired again as the build pairs them
    (`datasets.partners.pair_clips`), the files and records whose partner changed rewritten."""
    data = [c for c in record.clips if c.kind == "clip"]
    if not any(c.partner_clip_id for c in data):
        return record
    clips = [
        store.read_clip(store.clip_npz(out, take_id=record.take_id, clip_id=c.clip_id))
        for c in data
    ]
    paired = {c.clip_id: c for c in pair_clips(clips)}
    for old in clips:
        new = paired[old.clip_id]
        if new.partner_clip_id != old.partner_clip_id or not np.array_equal(
            new.partner_speaking, old.partner_speaking
        ):
            write_clip(store.clip_npz(out, take_id=record.take_id, clip_id=new.clip_id), new)
    rows = [
        replace(c, partner_clip_id=paired[c.clip_id].partner_clip_id) if c.kind == "clip" else c
        for c in record.clips
    ]
    return store.with_clips(record, rows)


def _judge(records: list[store.TakeRecord], qc: QCConfig) -> list[store.TakeRecord]:
    """Records with every clip's verdict from the absolute and dataset-relative checks."""
    metrics = {c.clip_id: ClipMetrics.from_dict(c.metrics) for r in records for c in r.data_clips}
    result = verdicts(metrics, qc)
    judged = []
    for r in records:
        clips = [
            replace(c, qc_status=result[c.clip_id][0], qc_reasons=tuple(result[c.clip_id][1]))
            if c.kind == "clip"
            else c
            for c in r.clips
        ]
        judged.append(store.with_clips(r, clips))
    return judged


def audio_znorm(records: Sequence[store.TakeRecord]) -> dict[str, store.ZNorm]:
    """Mean and std of every audio feature per subject and over all ("*"), from the per-take
    sums (every clip's frames weigh the same; a rejected clip's motion is bad, its audio is not)."""
    sums: dict[str, list[np.ndarray]] = {}
    for r in records:
        if r.failed or not r.audio.get("n"):
            continue
        for key in (r.subject, "*"):
            n, s, q = r.audio["n"], np.asarray(r.audio["sum"]), np.asarray(r.audio["sumsq"])
            if key in sums:
                sums[key] = [sums[key][0] + n, sums[key][1] + s, sums[key][2] + q]
            else:
                sums[key] = [np.asarray(float(n)), s, q]
    out = {}
    for key, (n, s, q) in sorted(sums.items()):
        mean = s / n
        std = np.sqrt(np.maximum(q / n - mean**2, 0.0))
        out[key] = store.ZNorm(mean=mean.tolist(), std=std.tolist())
    return out


def judged_with(out: Path) -> Config | None:
    """The defaults with the [qc] and [splits] sections the dataset in `out` was last judged
    with (`gesturebank qc --set` may have changed them), or None when there is no readable
    dataset.json. A re-run of build-dataset starts from it, so it does not silently undo them."""
    if not (Path(out) / store.DATASET_JSON).is_file():
        return None
    try:
        saved = store.read_dataset_json(out).config
    except InputError:  # an old or broken dataset.json: the build rewrites it
        return None
    return Config(qc=saved.qc, splits=saved.splits)


def _text(record: store.TakeRecord) -> str:
    return json.dumps(record.to_json_dict(), sort_keys=True)


def _summary(record: store.TakeRecord) -> store.TakeSummary:
    return store.TakeSummary(
        status="failed" if record.failed else "built",
        clips=len(record.data_clips),
        accepted=sum(c.qc_status == "accepted" for c in record.clips),
        seconds=record.seconds,
        visible_s=record.visible_s,
        usable_s=record.usable_s,
    )


def refresh(
    out: Path,
    config: Config,
    *,
    take_ids: Sequence[str] | None = None,
    videos_dir: Path | None = None,
    recheck: bool = False,
) -> list[str]:
    """Re-judge, then rewrite the records whose verdicts changed, manifest.parquet, dataset.json
    and the splits of the dataset in `out`, for the takes `take_ids` (default: every take
    record in the folder). `recheck`: measure every clip again from its arrays (`gesturebank
    qc`: the invariants re-applied to what the folder holds). Returns notes (e.g. why no
    subject-independent split was written)."""
    from gesturebank.audio.features import feature_dim

    out = Path(out)
    if videos_dir is None:
        try:
            videos_dir = Path(store.read_dataset_json(out).videos_dir)
        except Exception:  # no earlier dataset.json: the folder itself
            videos_dir = out
    terms = read_takes_toml(videos_dir)  # before anything is rewritten: a bad file stops it here
    before = store.take_records(out, take_ids)
    qc, name = config.qc, config.robot.profile
    measured = [
        _cut(
            out,
            _remeasure(out, r, qc=qc, profile=name, recheck=recheck),
            qc=qc,
            min_s=config.clips.min_s,
            profile=name,
        )
        for r in before
    ]
    records = _judge(measured, qc)
    for old, new in zip(before, records, strict=True):
        if _text(new) != _text(old):  # as text: NaN metrics compare equal
            store.write_record(out, new)
    table = store.write_manifest(out, records)
    kinds, statuses_all = table.column("kind").to_pylist(), table.column("qc_status").to_pylist()
    rows = list(zip(kinds, statuses_all, strict=True))
    statuses = [status for kind, status in rows if kind == "clip"]
    profile = pepper.load_profile(config.robot.profile)
    info = store.DatasetInfo(
        tool_version=__version__,
        videos_dir=str(Path(videos_dir).resolve()),
        config=config,
        config_digest=content_digest(config),
        joints=list(pepper.JOINTS),
        limits=profile.as_dict(),
        robot_profile=profile.name,
        rates=store.Rates(pose_hz=config.processing.rate_hz, audio_hz=1 / config.audio.winstep_s),
        audio_features=store.AudioFeatures(
            kind=config.audio.features,
            dim=feature_dim(config.audio),
            params=config.audio.model_dump(mode="json"),
        ),
        audio_znorm_by_subject=audio_znorm(records),
        clip_counts={s: statuses.count(s) for s in store.STATUSES},
        stretches_dropped=sum(kind == "span" and status != "failed" for kind, status in rows),
        takes={r.take_id: _summary(r) for r in records},
    )
    store.write_dataset_json(out, info)
    write_card(out, info=info, records=records, terms=terms)
    return write_splits(out, records=table.to_pylist(), config=config.splits)
