"""The project's own documents: licence, citation, packaging metadata."""

from __future__ import annotations

import tomllib
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
DISSERTATION = "Audio-driven upper-body motion synthesis on a humanoid robot"


def test_licence_file_and_spdx_expression() -> None:
    head = (ROOT / "LICENSE").read_text(encoding="utf-8")[:200]
    assert "Apache License" in head and "Version 2.0, January 2004" in head
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert project["project"]["license"] == "Apache-2.0"
    assert not [c for c in project["project"]["classifiers"] if c.startswith("License ::")]
    assert "Documentation" not in project["project"].get("urls", {})  # no site exists yet


def test_setuptools_reads_the_metadata_without_a_warning(monkeypatch: pytest.MonkeyPatch) -> None:
    from setuptools.config.pyprojecttoml import apply_configuration
    from setuptools.dist import Distribution

    monkeypatch.chdir(ROOT)  # license-files and readme are relative to the project
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the licence classifier/table deprecations fail here
        dist = apply_configuration(Distribution(), ROOT / "pyproject.toml")
    assert dist.metadata.license_expression == "Apache-2.0"


def test_citation_names_the_toolkit_and_the_dissertation() -> None:
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert cff["license"] == "Apache-2.0"
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    assert cff["version"] == version
    (thesis,) = cff["references"]
    assert thesis["title"] == DISSERTATION and thesis["year"] == 2018
    assert thesis["authors"] == [{"family-names": "Ondras", "given-names": "Jan"}]
    assert thesis["institution"]["name"] == "University of Cambridge"
