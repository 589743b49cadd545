"""The project's own documents: licence, citation, packaging metadata."""

from __future__ import annotations

import re
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


def _make_dry_run(goal: str) -> str:
    """The commands `make GOAL` would run on a fresh clone (no .venv yet), not run."""
    import subprocess

    venv = "/nonexistent-venv"
    r = subprocess.run(
        ["make", "-n", "-B", goal, f"VENV={venv}", "MEDIA=/nonexistent-media"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    return r.stdout


def _installed(text: str) -> set[str]:
    """Every `pip install` argument (package, -e target) in `text`, options and quotes left out."""
    found = set()
    for line in text.splitlines():
        _, sep, args = line.partition("pip install")
        if sep and not line.lstrip().startswith("#"):
            args = args.split("#")[0]
            found |= {a.strip("\"'") for a in args.split() if not a.startswith("-")}
    return found - {"pip"}  # `pip install --upgrade pip`


def test_install_by_hand_is_what_make_installs() -> None:
    """Issue 44: README's "Install by hand" left out silero-vad (every take then failed) and
    scenedetect; `make demo` installed every extra and the README never said so."""
    readme = (ROOT / "README.md").read_text()
    block = readme.split("## Install by hand", 1)[1].split("```sh", 1)[1].split("```", 1)[0]
    demo, test, setup = (_make_dry_run(g) for g in ("demo", "test", "setup"))
    assert _installed(block) == _installed(demo) | _installed(setup)
    assert _installed(setup) <= _installed(test)  # `make test` installs everything too
    every = {a for a in _installed(setup) if a.startswith(".[")}
    assert len(every) == 1 and "train" in next(iter(every))
    assert not any(a.startswith(".[") for a in _installed(demo)), "make demo: no extras"
    assert {"silero-vad", "scenedetect", "mediapipe"} <= {
        a.split("==")[0] for a in _installed(demo)
    }
    section = readme.split("## Install by hand", 1)[1].split("\n## ", 1)[0]
    assert section.count(" GB") >= 2  # the sizes of both installs are given
    # and what each downloads (issue 44: only installed sizes were given)
    assert re.search(r"To download: about \d+ MB for\s+`make demo`", section), section
    assert re.search(r"about [\d.]+ GB for `make setup`", section), section


def test_a_missing_extra_is_one_line_naming_it(tmp_path: Path) -> None:
    """Without the `train` extra (torch hidden from the import system), `train` says which
    extra to install, in one line, exit 2, instead of a traceback."""
    import subprocess
    import sys

    argv = ["gesturebank", "train", str(tmp_path), "--out", str(tmp_path / "m")]
    script = (
        "import sys; sys.modules['torch'] = None\n"
        "from gesturebank.cli import main\n"
        f"sys.argv = {argv!r}\n"
        "main()\n"
    )
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=False)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "'train' extra" in lines[0], r.stderr


def test_gitignore_covers_what_the_readme_recipes_write(tmp_path: Path) -> None:
    """Issue 44: the README recipe's outputs were untracked files `.gitignore` did not cover.
    Every `--out` and dataset folder its recipes write in the checkout is ignored."""
    import re
    import shutil
    import subprocess

    readme = (ROOT / "README.md").read_text()
    recipes = [
        readme.split(f"## {title}", 1)[1].split("\n## ", 1)[0]
        for title in ("From your own videos to Pepper", "What `make demo` does")
    ]
    written = set()
    for text in recipes:  # in code and in prose (`--out played.csv`, across a line break)
        written |= set(re.findall(r"--out\s+([\w.-]+)", text))
        written |= {ln.split()[2] for ln in text.splitlines() if ln.startswith("build-dataset ")}
    assert {"my-dataset", "model", "angles.csv", "pepper.mp4", "played.csv"} <= written
    repo = tmp_path / "repo"  # a fresh repository holding the project's .gitignore alone
    repo.mkdir()
    shutil.copy(ROOT / ".gitignore", repo / ".gitignore")
    subprocess.run(["git", "init", "-q", str(repo)], check=True)
    for name in sorted(written):
        r = subprocess.run(["git", "check-ignore", "-q", name], cwd=repo, check=False)
        assert r.returncode == 0, f"{name}: not ignored"
