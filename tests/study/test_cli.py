"""`gesturebank study serve` and `gesturebank study analyse` as a user runs them."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from gesturebank.study.app import create_app
from tests.study.test_app import PREFER, RATINGS, _answer_all, _join

GESTUREBANK = str(Path(sys.executable).parent / "gesturebank")


def test_serve_listens_on_loopback_and_prints_the_operator_token(study: Path) -> None:
    proc = subprocess.Popen(
        [GESTUREBANK, "study", "serve", str(study), "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = proc.stdout.readline().split("participants: ", 1)[1].strip()
        token_line = proc.stdout.readline()
        assert url.startswith("http://127.0.0.1:")
        operator = (study / "operator-token").read_text().strip()
        assert operator in token_line
        with urllib.request.urlopen(url, timeout=30) as reply:
            assert reply.status == 200
            assert reply.headers["Content-Security-Policy"].startswith("default-src 'none'")
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(f"{url}export.csv", timeout=30)
        assert refused.value.code == 403
        asked = urllib.request.Request(
            f"{url}export.csv", headers={"Authorization": f"Bearer {operator}"}
        )
        with urllib.request.urlopen(asked, timeout=30) as reply:
            assert reply.read().decode().startswith("participant,trial,kind,")
    finally:
        proc.send_signal(signal.SIGINT)  # as Ctrl-C
        proc.communicate(timeout=30)
    assert proc.returncode == 0


def test_analyse_prints_the_tables(study: Path) -> None:
    client = create_app(study).test_client()
    for n in (1, 2):
        _answer_all(client, _join(client), RATINGS[n], PREFER[n])
    from rich.console import Console

    from gesturebank.cli.study import analyse_command

    wide = Console(width=160, record=True, file=io.StringIO())  # rich's tables, unwrapped
    analyse_command(folder=study, console=wide)
    text = wide.export_text()
    assert "2 finished, 0 partial" in text and "analysed: 2 (finished only)" in text
    lines = text.splitlines()
    mlp = next(ln for ln in lines if "│ mlp " in ln and "4 " in ln)
    assert "51.2" in mlp and "37.7 – 64.8" in mlp  # 51.25 ± 13.588
    pair = next(ln for ln in lines if "lstm" in ln and "mlp" in ln and "wilcoxon" in ln)
    assert "12.5" in pair and "0.125" in pair
    ab = next(ln for ln in lines if "3/4 (75 %)" in ln)
    assert "0.625" in ab
    assert (study / "analysis" / "ratings.png").is_file()
    # issue 44: at 80 columns the paired tests' eight columns were cut (`stati…`, `p (Ho…`)
    narrow = subprocess.run(
        [GESTUREBANK, "study", "analyse", str(study)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env={**os.environ, "COLUMNS": "80"},
    )
    assert narrow.returncode == 0, narrow.stderr
    lines = [ln for ln in narrow.stdout.splitlines() if not ln.startswith("plot written to ")]
    assert all(len(ln.rstrip()) <= 80 and "…" not in ln for ln in lines), narrow.stdout
    assert "analysed: 2 (finished only)" in " ".join(ln.strip() for ln in lines)
    mlp = next(ln for ln in lines if ln.strip().startswith("mlp ") and " 4 " in ln)
    assert "51.2" in mlp and "37.7 – 64.8" in mlp
    at = lines.index(next(ln for ln in lines if ln.strip().startswith("lstm vs mlp: n 4")))
    assert "mean a − b 12.5" in lines[at], narrow.stdout
    assert "wilcoxon statistic" in lines[at + 1] and "p 0.125," in lines[at + 1]
    pref = lines.index(next(ln for ln in lines if "prefer lstm" in ln))
    assert "3/4 (75 %), p 0.625, p (Holm) 0.625" in lines[pref + 1], narrow.stdout


def test_analyse_without_answers_is_a_one_line_error(study: Path) -> None:
    r = subprocess.run(
        [GESTUREBANK, "study", "analyse", str(study)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "responses.sqlite: no answers yet" in r.stderr
