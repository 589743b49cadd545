"""The QC dashboard of a clip dataset, written as static HTML pages that work offline, and kept:
a take page is only rendered again when what it shows changed.

    OUT/qc/index.html          the dataset at a glance (`report.render.index_page`)
    OUT/qc/takes/<id>.html     one take: timeline, main speaker, preview strip with the main
                               speaker's 2D skeleton, and per clip its verdict, metrics and the 11
                               angles raw vs processed with the robot's limits, masked spans and
                               repairs (`report.render.take_page`)

Pages are drawn from the records and clips as they are (`datasets.refresh` judges the clips). A
take page carries a key of what it shows (the report's code, the record, the clips' files, the
preview, the limits and the QC thresholds), so an unchanged dataset costs a read of its records.
"""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

from gesturebank.datasets import store
from gesturebank.fileio import write_bytes_atomic
from gesturebank.report import data, render
from gesturebank.report.data import PAGES_DIR
from gesturebank.report.render import SCRIPT, STYLE, index_page, render_take

QC_DIR = "qc"
_KEY = re.compile(r"<!-- page-key (\w+) -->")


# --------------------------------------------------------------------------------------------------
# Pages kept when unchanged


def _stat(path: Path) -> tuple[int, int] | None:
    try:
        s = path.stat()
    except OSError:
        return None
    return s.st_size, s.st_mtime_ns


def _page_key(out: Path, record: store.TakeRecord, info: store.DatasetInfo, code: str) -> str:
    """What a take page shows depends on: the report's code, the record, the clips' files, the
    preview, the robot's limits and the QC thresholds."""
    folder = store.take_dir(out, record.take_id)
    parts = [
        code,
        json.dumps(record.to_json_dict(), sort_keys=True),
        json.dumps([info.joints, info.limits], sort_keys=True),
        info.config.qc.model_dump_json(),  # the thresholds beside the metrics
        _stat(folder / store.PREVIEW),
        [
            _stat(store.clip_npz(out, take_id=record.take_id, clip_id=c.clip_id))
            for c in record.data_clips
        ],
    ]
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:20]


def _existing_key(page: Path) -> str | None:
    try:
        with open(page, encoding="utf-8") as f:
            head = f.read(200)
    except OSError:
        return None
    found = _KEY.search(head)
    return found.group(1) if found else None


def _write_if_changed(path: Path, text: str) -> bool:
    data = text.encode("utf-8")
    try:
        if path.read_bytes() == data:
            return False
    except OSError:
        pass
    write_bytes_atomic(path, data)
    return True


def _source() -> str:
    """The code that draws the pages (a change to it draws every page again)."""
    files = (data.__file__, render.__file__, __file__)
    return "".join(Path(f).read_text() for f in files if f)


def write_dashboard(out: Path) -> Path:
    """Write OUT/qc/index.html and OUT/qc/takes/<take_id>.html from the dataset's records and
    clips as they are; returns the index. Only pages whose take changed are rendered (and the
    index only rewritten when it changed); pages of takes no longer in the dataset go."""
    out = Path(out)
    info = store.read_dataset_json(out)
    records = store.take_records(out)
    pages = out / QC_DIR / PAGES_DIR
    pages.mkdir(parents=True, exist_ok=True)
    code = hashlib.sha256((_source() + STYLE + SCRIPT).encode()).hexdigest()
    wanted = set()
    for record in records:
        page = pages / f"{record.take_id}.html"
        wanted.add(page.name)
        key = _page_key(out, record, info, code)
        if _existing_key(page) != key:
            write_bytes_atomic(
                page, render_take(out, record=record, info=info, key=key).encode("utf-8")
            )
    for page in pages.glob("*.html"):
        if page.name not in wanted:
            page.unlink(missing_ok=True)
    index = out / QC_DIR / "index.html"
    _write_if_changed(index, index_page(out, info=info, records=records))
    return index
