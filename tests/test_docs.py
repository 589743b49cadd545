"""The documentation site (docs/) against the code it describes: the generated configuration
reference covers every key, the dataset-format page names every file field, and every section of
docs/architecture.md the code cites exists. `make docs` builds the site itself (strict)."""

from __future__ import annotations

import dataclasses
import importlib.util
import re
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from pydantic import BaseModel

import gesturebank
from gesturebank.clip import Clip
from gesturebank.config import Config
from gesturebank.datasets.store import MANIFEST_SCHEMA, ClipRecord, DatasetInfo, TakeRecord
from gesturebank.poses import Pose2D, Pose3D
from gesturebank.skeletons import COCO17

REPO = Path(gesturebank.__file__).parent.parent
DOCS = REPO / "docs"


def _hook() -> ModuleType:
    path = DOCS / "hooks" / "config_reference.py"
    spec = importlib.util.spec_from_file_location("config_reference", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _leaf_keys(model: type[BaseModel], prefix: str = "") -> list[str]:
    keys = []
    for key, field in model.model_fields.items():
        name = field.alias or key  # the key as written in TOML
        ann = field.annotation
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            keys += _leaf_keys(ann, f"{prefix}{name}.")
        else:
            keys.append(prefix + name)
    return keys


def _reference_rows() -> dict[str, list[str]]:
    """Dotted key → its table cells, read back from the generated Markdown."""
    rows: dict[str, list[str]] = {}
    section = ""
    for line in _hook().reference().splitlines():
        if heading := re.fullmatch(r"### `\[(.+)\]`", line):
            section = heading.group(1) + "."
        elif line.startswith("| `"):
            cells = [c.strip() for c in line.strip("|").split(" | ")]
            rows[section + cells[0].strip("`")] = cells
    return rows


def test_the_config_reference_has_every_key_once() -> None:
    rows = _reference_rows()
    keys = _leaf_keys(Config)
    assert len(keys) > 200
    assert sorted(rows) == sorted(keys)


def test_the_config_reference_shows_default_unit_range_and_description() -> None:
    rows = _reference_rows()
    # key | type | default | unit | allowed | description
    assert rows["processing.cutoff_hz"][2:4] == ["`4.0`", "Hz"]
    assert rows["audio.nfilt"][2:5] == ["`26`", "", "≥ 1, ≤ 128"]
    assert rows["video.end_s"][1:5] == ["float or none", "`none`", "s", "> 0"]
    assert rows["shots.detector"][1] == "`'content'` \\| `'none'`"
    assert rows["splits.sd_fractions"][2] == "`[0.7, 0.15, 0.15]`"
    assert rows["train.lstm.max_epochs"][2] == "`100`"
    assert "precomputed" in rows["detector.openpose-json.json_suffix"][5]
    cell = rows["detector.openpose-json.json_suffix"][5]
    assert "&lt;video stem&gt;" in cell  # no raw HTML in a cell


def test_the_dataset_format_page_names_every_field() -> None:
    text = (DOCS / "dataset-format.md").read_text(encoding="utf-8")
    pose2d = Pose2D(np.zeros((1, len(COCO17), 3)), np.zeros(1), COCO17.name, (8, 8))
    pose3d = Pose3D(np.zeros((1, len(COCO17), 3)), np.zeros((1, len(COCO17))), np.zeros(1))
    names = [
        *MANIFEST_SCHEMA.names,
        *DatasetInfo.model_fields,
        *(f.name for f in dataclasses.fields(TakeRecord)),
        *(f.name for f in dataclasses.fields(ClipRecord)),
        *(f.name for f in dataclasses.fields(Clip) if f.name not in ("pose2d", "pose3d")),
        *pose2d.to_arrays("pose2d_"),
        *pose3d.to_arrays("pose3d_"),
    ]
    missing = sorted({n for n in names if f"`{n}`" not in text})
    assert not missing, f"docs/dataset-format.md does not name: {missing}"
    assert f"schema version {DatasetInfo.model_fields['schema_version'].default}" in text.lower()


def test_every_cited_architecture_section_exists() -> None:
    text = (DOCS / "architecture.md").read_text(encoding="utf-8")
    headings = set(re.findall(r"^#+ (.+)$", text, flags=re.MULTILINE))
    cited: dict[str, set[str]] = {}
    for folder in ("gesturebank", "tests", "benchmarks"):
        for path in sorted((REPO / folder).rglob("*.py")):
            if path == Path(__file__):
                continue  # this test names the old document to forbid it
            source = path.read_text(encoding="utf-8")
            assert "DESIGN.md" not in source, f"{path}: cites DESIGN.md, not in the repository"
            for section in re.findall(r'docs/architecture\.md\s+"([^"]+)"', source):
                cited.setdefault(section, set()).add(str(path.relative_to(REPO)))
    assert len(cited) >= 5
    unknown = {s: sorted(p) for s, p in cited.items() if s not in headings}
    assert not unknown, f"sections cited but not in docs/architecture.md: {unknown}"


@pytest.mark.parametrize(
    ("document", "heading"), [("docs/architecture.md", "## Layout"), ("README.md", "## Layout")]
)
def test_the_layout_names_everything_in_the_package(document: str, heading: str) -> None:
    """The architecture's "Layout" and the README's list every module and folder of
    `ls gesturebank/`."""
    text = (REPO / document).read_text(encoding="utf-8")
    layout = text.partition(f"\n{heading}\n")[2].partition("\n## ")[0]
    package = REPO / "gesturebank"
    entries = [p.name + "/" if p.is_dir() else p.name for p in sorted(package.iterdir())]
    shown = [e for e in entries if e.endswith((".py", "/")) and e != "__pycache__/"]
    assert len(shown) > 15
    # a name stands alone: between spaces, line ends or code backticks
    named = [rf"(^|[\s`]){re.escape(e)}([\s`]|$)" for e in shown]
    missing = [
        e for e, pattern in zip(shown, named, strict=True) if not re.search(pattern, layout, re.M)
    ]
    assert not missing, f"{document} {heading} lacks: {missing}"
