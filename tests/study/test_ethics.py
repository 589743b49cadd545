"""What an ethics board looks at, over HTTP (Flask's test client, and a real server on
127.0.0.1): the consent page from design.toml with the real length, poster frames, the
Host allow-list; and the analysis: finished and partial participants apart, intervals within
the scale, Holm's correction against a hand-computed table."""

from __future__ import annotations

import http.client
import io
import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from gesturebank.errors import InputError
from gesturebank.study.analyse import analyse, holm, mean_ci
from gesturebank.study.app import create_app
from gesturebank.study.design import load_design
from gesturebank.study.posters import poster_path
from tests.study.helpers import serving
from tests.study.test_app import RATINGS, _answer_all, _form, _join, _shown

DESIGN = """\
title = "Gestures of a talking robot"
researcher = "Dr Ada Example, Robotics Lab, Example University"
contact = "ada@example.org"
ethics_reference = "ERB-2026-042 <approved>"
consent_text = \"\"\"You will watch videos of a robot.

You can stop at any time.\"\"\"
data_use = "Answers are kept for five years, then deleted."

[mushra_questions]
appropriate = "Fits the speech?"
natural = "Looks natural?"
"""


def test_consent_page_shows_design_toml_and_the_real_length(study: Path) -> None:
    (study / "design.toml").write_text(DESIGN)
    page = create_app(study).test_client().get("/").get_data(as_text=True)
    assert "<h1 id='title'>Gestures of a talking robot</h1>" in page
    assert "Dr Ada Example, Robotics Lab, Example University" in page
    assert "ada@example.org" in page
    assert "ERB-2026-042 &lt;approved&gt;" in page  # escaped, not markup
    assert "<p>You will watch videos of a robot.</p><p>You can stop at any time.</p>" in page
    assert "Answers are kept for five years, then deleted." in page
    # 2 sentences × (a rating page: 4 videos + the reference on top, 2 questions; an A/B page):
    # 60 s reading + 2 × (2 views × 5 × 1 s + 10 s × 4 × 2 + 2 views × 2 × 1 s + 10 s) = 268 s
    assert "<b id='pages'>4</b> pages" in page and "<b id='minutes'>5</b> minutes" in page
    assert "estimated from the videos' lengths" in page
    assert "10 minutes" not in page


def test_without_design_toml_the_page_leaves_out_what_is_not_given(study: Path) -> None:
    page = create_app(study).test_client().get("/").get_data(as_text=True)
    assert "id='researcher'" not in page and "id='ethics'" not in page
    # 60 s + 2 × (2 × 5 × 1 s + 10 s × 4 + 2 × 2 × 1 s + 10 s) = 188 s → 4 minutes
    assert "<b id='pages'>4</b> pages" in page and "<b id='minutes'>4</b> minutes" in page


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            'ethic_reference = "X"\n',
            "unknown key 'ethic_reference' (did you mean ethics_reference?)",
        ),
        ('ab = "sometimes"\n', "ab: Input should be a valid boolean"),
        ('title = ""\n', "title: String should have at least 1 character"),
        ('[mushra_questions]\n"a b" = "?"\n', "id 'a b' must be letters, digits, _ or -"),
    ],
)
def test_a_bad_design_toml_is_one_line_naming_the_file(
    study: Path, text: str, message: str
) -> None:
    (study / "design.toml").write_text(text)
    with pytest.raises(InputError) as info:
        load_design(study)
    assert str(info.value).startswith(f"{study / 'design.toml'}: ")
    assert message in str(info.value) and "\n" not in str(info.value)


def test_every_video_has_a_poster_frame(study: Path) -> None:
    client = create_app(study).test_client()
    token = _join(client)
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    shown = _shown(client, token)
    assert shown is not None
    for sid in shown.items:
        assert f"poster='/p/{token}/poster/{sid}' src='/p/{token}/video/{sid}'" in page
        reply = client.get(f"/p/{token}/poster/{sid}")
        assert reply.status_code == 200 and reply.mimetype == "image/jpeg"
        image = np.asarray(Image.open(io.BytesIO(reply.data)).convert("L"), float)
        assert image.shape == (120, 160) and image.std() > 10  # a picture, not a black box
        assert poster_path(study, sid).is_file()
    assert client.get(f"/p/{token}/poster/nope").status_code == 404
    assert client.get(f"/p/{'x' * 43}/poster/{shown.items[0]}").status_code == 404


def test_host_headers_outside_the_allow_list_are_refused(study: Path) -> None:
    client = create_app(study, allowed_hosts=["127.0.0.1", "study.example"]).test_client()
    for host in ("127.0.0.1:8000", "study.example", "STUDY.example.:80"):
        assert client.get("/", headers={"Host": host}).status_code == 200, host
    for host in ("rebind.example:8000", "localhost", "127.0.0.1.evil.example"):
        assert client.get("/", headers={"Host": host}).status_code == 403, host
    for host in ("a b", "127.0.0.1:80x", ""):
        assert client.get("/", headers={"Host": host}).status_code == 400, host
    # a rebound page's form post creates no participant
    reply = client.post("/start", data={"consent": "yes"}, headers={"Host": "rebind.example"})
    assert reply.status_code == 403
    assert not (study / "responses.sqlite").is_file() or analyse_count(study) == 0


def analyse_count(study: Path) -> int:
    from gesturebank.study import db

    with db.connect(study / db.DATABASE) as con:
        return int(con.execute("SELECT COUNT(*) FROM participants").fetchone()[0])


@pytest.fixture()
def served(study: Path) -> Iterator[int]:
    with serving(study, ["study.example"]) as port:
        yield port


def test_a_real_server_answers_its_own_names_only(served: int) -> None:
    def status(host: str) -> int:
        con = http.client.HTTPConnection("127.0.0.1", served, timeout=30)
        try:
            con.request("GET", "/", headers={"Host": host})
            return con.getresponse().status
        finally:
            con.close()

    assert status(f"127.0.0.1:{served}") == 200
    assert status(f"localhost:{served}") == 200  # loopback: this machine's own names
    assert status(f"study.example:{served}") == 200  # --allow-host
    assert status(f"rebind.example:{served}") == 403


def test_finished_and_partial_participants_count_apart(study: Path) -> None:
    client = create_app(study).test_client()
    _answer_all(client, _join(client), RATINGS[1], {a: "lstm" for a in RATINGS[1]})
    half = _join(client)  # answers the first page only
    shown = _shown(client, half)
    assert shown is not None
    answers = dict.fromkeys(["mlp", "lstm", "ground-truth", "anchor"], 0)
    assert client.post(f"/p/{half}/answer", data=_form(shown, answers)).status_code == 303
    _join(client)  # consents, answers nothing
    finished = analyse(study, plot=False)
    assert (finished.finished, finished.partial, finished.no_answer) == (1, 1, 1)
    assert finished.participants == 1
    assert all(r["n"] == 2 for r in finished.ratings)  # the finished one's two rating pages
    both = analyse(study, plot=False, include_partial=True)
    assert both.participants == 2
    rated = 1 if shown.kind == "mushra" else 0
    assert sum(r["n"] for r in both.ratings) == 8 + 4 * rated


def test_confidence_intervals_stay_on_the_scale() -> None:
    # 100, 100, 60: mean 86.667, s² = (2 × 13.333² + 26.667²) / 2 = 533.33, s / √3 = 13.333;
    # t(0.975, 2) = 4.302653 (table) → ± 57.369: 29.298 – 144.036, clipped to ≤ 100
    mean, low, high = mean_ci(values=np.array([100.0, 100.0, 60.0]), scale=(0.0, 100.0))
    assert mean == pytest.approx(86.6667, abs=1e-4)
    assert low == pytest.approx(86.6667 - 57.3687, abs=1e-3) and high == 100.0
    _, low, high = mean_ci(values=np.array([0.0, 0.0, 40.0]), scale=(0.0, 100.0))
    assert low == 0.0 and high == pytest.approx(13.3333 + 57.3687, abs=1e-3)


# Holm by hand: sort ascending, multiply the i-th (from 1) of m by m − i + 1, carry the running
# maximum, cap at 1. NaN (no test) stays NaN and is not counted in m.
HOLM_TABLE = [
    # raw p → adjusted p
    ([0.01, 0.04, 0.03, 0.005], [0.03, 0.06, 0.06, 0.02]),  # 4×.005, 3×.01, 2×.03, max(.06, .04)
    ([0.2, 0.9, 0.6], [0.6, 1.0, 1.0]),  # 3×.2, min(1, 2×.6), max(1, .9)
    ([0.5, 0.3], [0.6, 0.6]),  # 2×.3, max(.6, .5)
    ([0.04, math.nan, 0.01], [0.04, math.nan, 0.02]),  # m = 2
    ([0.05], [0.05]),
]


@pytest.mark.parametrize(("raw", "adjusted"), HOLM_TABLE)
def test_holm_matches_the_hand_computed_table(raw: list[float], adjusted: list[float]) -> None:
    np.testing.assert_allclose(holm(np.array(raw)), adjusted, rtol=1e-12)


def test_analysis_gives_holm_beside_raw_p_per_question(study: Path) -> None:
    client = create_app(study).test_client()
    for n in (1, 2):
        _answer_all(client, _join(client), RATINGS[n], {a: "lstm" for a in RATINGS[n]})
    result = analyse(study, plot=False)
    tests = [t for t in result.tests if t["question"] == "appropriate"]
    assert len(tests) == 6
    raw = sorted(t["p"] for t in tests)
    smallest = min(tests, key=lambda t: t["p"])
    assert smallest["p_holm"] == pytest.approx(min(1.0, 6 * raw[0]))
    assert all(t["p_holm"] >= t["p"] for t in tests)


def test_cli_analyse_says_who_counts_and_prints_holm(study: Path) -> None:
    import os
    import subprocess
    import sys

    client = create_app(study).test_client()
    for n in (1, 2):
        _answer_all(client, _join(client), RATINGS[n], {a: "lstm" for a in RATINGS[n]})
    _join(client)  # consented, nothing more
    gesturebank = str(Path(sys.executable).parent / "gesturebank")
    env = {**os.environ, "COLUMNS": "200"}
    for flag, used in (([], "2 (finished only)"), (["--include-partial"], "2 (finished and")):
        r = subprocess.run(
            [gesturebank, "study", "analyse", str(study), *flag],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
            env=env,
        )
        assert r.returncode == 0, r.stderr
        assert "2 finished, 0 partial (stopped half-way), 1 consented without" in r.stdout
        assert f"analysed: {used}" in r.stdout
        assert "p (Holm)" in r.stdout


def test_cli_serve_takes_allow_host(study: Path) -> None:
    import signal
    import subprocess
    import sys

    gesturebank = str(Path(sys.executable).parent / "gesturebank")
    args = [gesturebank, "study", "serve", str(study), "--port", "0"]
    proc = subprocess.Popen(
        [*args, "--allow-host", "study.example", "--allow-host", "other.example"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = proc.stdout.readline().split("participants: ", 1)[1].strip()
        port = int(url.rstrip("/").rsplit(":", 1)[1])
        for host, expected in (("study.example", 200), ("other.example", 200), ("x.test", 403)):
            con = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
            con.request("GET", "/", headers={"Host": f"{host}:{port}"})
            assert con.getresponse().status == expected, host
            con.close()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=30)
