"""The study app as strangers would poke at it (Flask's test client): consent first, each token
sees only its own answers, the export and the key need the operator token, bad or replayed
submissions change nothing; and two participants' answers give the hand-computed analysis."""

from __future__ import annotations

import csv
import io
import json
import stat
import tomllib
from pathlib import Path
from typing import Any

import pytest
from flask.testing import FlaskClient

from gesturebank.study import db
from gesturebank.study.analyse import analyse
from gesturebank.study.app import OPERATOR_TOKEN, create_app
from gesturebank.study.design import load_design, participant_order
from tests.study.conftest import AUDIOS, IDS, MODELS
from tests.study.helpers import Shown, shown_trial

MODEL_OF = {sid: model for (_, model), sid in IDS.items()}
AUDIO_OF = {sid: audio for (audio, _), sid in IDS.items()}


@pytest.fixture()
def client(study: Path) -> FlaskClient:
    return create_app(study).test_client()


def _join(client: FlaskClient) -> str:
    reply = client.post("/start", data={"consent": "yes"})
    assert reply.status_code == 303
    token = reply.headers["Location"].split("/")[2]
    assert len(token) >= 40
    return token


def _shown(client: FlaskClient, token: str) -> Shown | None:
    reply = client.get(f"/p/{token}/trial")
    assert reply.status_code == 200
    return shown_trial(reply.get_data(as_text=True))


def _form(shown: Shown, answers: dict[str, int], prefer: str = "lstm") -> dict[str, str]:
    """The form for `shown`: ratings by model (MUSHRA) or the side showing `prefer` (A/B)."""
    if shown.kind == "ab":
        side = [MODEL_OF[s] for s in shown.items].index(prefer)
        return {"trial": shown.trial, "choice": str(side)}
    form = {"trial": shown.trial}
    for k, sid in enumerate(shown.items):
        form[f"r-appropriate-{k}"] = str(answers[MODEL_OF[sid]])
    return form


def _rows(study: Path) -> list[dict[str, Any]]:
    with db.connect(study / db.DATABASE) as con:
        return db.all_answers(con)


def _answer_all(
    client: FlaskClient, token: str, ratings: dict[str, dict[str, int]], prefer: dict[str, str]
) -> None:
    while (shown := _shown(client, token)) is not None:
        audio = AUDIO_OF[shown.items[0]]
        reply = client.post(f"/p/{token}/answer", data=_form(shown, ratings[audio], prefer[audio]))
        assert reply.status_code == 303, reply.get_data(as_text=True)


def test_design_from_the_stimuli(study: Path) -> None:
    design = load_design(study)
    kinds = sorted((t.kind, t.audio, len(t.stimuli)) for t in design.trials.values())
    assert kinds == [("ab", a, 2) for a in AUDIOS] + [("mushra", a, 4) for a in AUDIOS]
    mushra = design.trials[f"mushra-{AUDIOS[0]}"]
    assert mushra.reference == IDS[(AUDIOS[0], "ground-truth")]
    assert IDS[(AUDIOS[0], "anchor")] in mushra.stimuli  # the hidden anchor is rated
    one, two = (participant_order(design=design, seed=5, number=n) for n in (1, 2))
    assert [t["trial"] for t in one] == [t["trial"] for t in two]  # same seed, same order
    for a, b in zip(one, two, strict=True):
        if a["trial"].startswith("ab-"):
            assert a["items"] == b["items"][::-1]  # consecutive participants: sides swapped
    sides = [t["items"][0] for t in one if t["trial"].startswith("ab-")]
    assert sorted(MODEL_OF[s] for s in sides) == ["lstm", "mlp"]  # and within a participant


def test_design_toml_sets_the_questions(study: Path) -> None:
    text = '[mushra_questions]\nappropriate = "Fits the speech?"\nnatural = "Looks natural?"\n'
    (study / "design.toml").write_text(text)
    assert tomllib.loads(text)["mushra_questions"]
    client = create_app(study).test_client()
    token = _join(client)
    while (shown := _shown(client, token)) is not None and shown.kind != "mushra":
        client.post(f"/p/{token}/answer", data=_form(shown, {}))
    assert shown is not None
    form = _form(shown, dict.fromkeys(MODELS, 50))
    assert client.post(f"/p/{token}/answer", data=form).status_code == 400  # natural missing
    form |= {f"r-natural-{k}": "40" for k in range(4)}
    assert client.post(f"/p/{token}/answer", data=form).status_code == 303
    assert {r["question"] for r in _rows(study)} >= {"appropriate", "natural"}


def test_consent_cannot_be_skipped(client: FlaskClient, study: Path) -> None:
    assert client.post("/start", data={}).status_code == 400
    assert client.post("/start", data={"consent": "no"}).status_code == 400
    assert client.get("/start").status_code == 405
    with db.connect(study / db.DATABASE) as con:
        assert con.execute("SELECT COUNT(*) FROM participants").fetchone()[0] == 0
    assert client.get("/p/not-a-token/trial").status_code == 404
    page = client.get("/").get_data(as_text=True)
    assert "name='consent'" in page


def test_pages_are_self_contained_with_a_strict_policy(client: FlaskClient) -> None:
    token = _join(client)
    for url in ("/", f"/p/{token}/", f"/p/{token}/trial"):
        reply = client.get(url)
        policy = reply.headers["Content-Security-Policy"]
        assert policy.startswith("default-src 'none'") and "unsafe-inline" not in policy
        assert reply.headers["Referrer-Policy"] == "no-referrer"
        body = reply.get_data(as_text=True)
        assert (
            "http://" not in body
            and "https://" not in body
            and "//" not in body.replace("<!doctype", "")
        )


def test_operator_token_guards_export_and_key(client: FlaskClient, study: Path) -> None:
    token_file = study / OPERATOR_TOKEN
    assert stat.S_IMODE(token_file.stat().st_mode) == 0o600
    operator = token_file.read_text().strip()
    participant = _join(client)
    for url in ("/export.csv", "/key.json"):
        assert client.get(url).status_code == 403
        assert (
            client.get(url, headers={"Authorization": f"Bearer {participant}"}).status_code == 403
        )
        assert client.get(url, headers={"Authorization": "Bearer "}).status_code == 403
        assert client.get(f"{url}?token={operator}").status_code == 403  # header only
    key = client.get("/key.json", headers={"Authorization": f"Bearer {operator}"})
    assert key.status_code == 200 and key.json == json.loads((study / "key.json").read_text())
    # participants never see a model name
    for page in (f"/p/{participant}/", f"/p/{participant}/trial", f"/p/{participant}/answers"):
        text = client.get(page).get_data(as_text=True).replace(participant, "")
        assert not any(m in text for m in MODELS), page
    assert create_app(study) and token_file.read_text().strip() == operator  # kept on restart


def test_a_token_reads_and_writes_only_its_own_answers(client: FlaskClient, study: Path) -> None:
    alice, bob = _join(client), _join(client)
    shown = _shown(client, bob)
    assert shown is not None
    values = dict.fromkeys(MODELS, 33)
    client.post(f"/p/{bob}/answer", data=_form(shown, values))
    bobs = _rows(study)
    assert len(bobs) == len(shown.items) and {r["participant"] for r in bobs} == {2}
    assert client.get(f"/p/{alice}/answers").json == {"answers": []}
    assert len(client.get(f"/p/{bob}/answers").json["answers"]) == len(shown.items)
    # Alice sending Bob's trial writes Alice's rows (if the trial is one of hers), never Bob's.
    reply = client.post(f"/p/{alice}/answer", data=_form(shown, dict.fromkeys(MODELS, 90)))
    assert reply.status_code == 303
    assert [r for r in _rows(study) if r["participant"] == 2] == bobs
    alices = client.get(f"/p/{alice}/answers").json["answers"]
    assert {r["rating"] or r["chosen"] for r in alices} <= {90, 0, 1}
    # a token is not an operator token
    assert (
        client.get("/export.csv", headers={"Authorization": f"Bearer {alice}"}).status_code == 403
    )


@pytest.mark.parametrize(
    "change",
    [
        {"r-appropriate-0": "101"},
        {"r-appropriate-0": "-1"},
        {"r-appropriate-0": "50.5"},
        {"r-appropriate-0": "5e1"},
        {"r-appropriate-0": "٥٠"},  # Arabic-Indic digits are not ASCII digits
        {"r-appropriate-0": ""},
        {"r-appropriate-3": None},  # one slider missing
        {"trial": "mushra-nope"},
        {"trial": "' OR 1=1 --"},
        {"extra": "1"},
        {"comment": "x" * 501},
        {"comment": "x" * 70_000},  # more than the form limit
    ],
)
def test_malformed_submissions_are_refused_and_change_nothing(
    client: FlaskClient, study: Path, change: dict[str, str | None]
) -> None:
    token = _join(client)
    shown = _shown(client, token)
    while shown is not None and shown.kind != "mushra":  # answer A/B pages until a rating page
        client.post(f"/p/{token}/answer", data=_form(shown, {}))
        shown = _shown(client, token)
    assert shown is not None
    before = _rows(study)
    form: dict[str, Any] = _form(shown, dict.fromkeys(MODELS, 50)) | change
    form = {k: v for k, v in form.items() if v is not None}
    reply = client.post(f"/p/{token}/answer", data=form)
    assert 400 <= reply.status_code < 500, reply.status_code
    assert _rows(study) == before
    assert _shown(client, token) == shown  # still on the same page


def test_bad_ab_choice_is_refused(client: FlaskClient, study: Path) -> None:
    token = _join(client)
    shown = _shown(client, token)
    while shown is not None and shown.kind != "ab":
        client.post(f"/p/{token}/answer", data=_form(shown, dict.fromkeys(MODELS, 50)))
        shown = _shown(client, token)
    assert shown is not None
    before = _rows(study)
    for choice in ("2", "-1", "A", "", "0 "):
        reply = client.post(f"/p/{token}/answer", data={"trial": shown.trial, "choice": choice})
        assert reply.status_code == 400, choice
    assert client.post(f"/p/{token}/answer", data={"trial": shown.trial}).status_code == 400
    assert _rows(study) == before


def test_a_replayed_submission_is_stored_once(client: FlaskClient, study: Path) -> None:
    token = _join(client)
    shown = _shown(client, token)
    assert shown is not None
    form = _form(shown, dict.fromkeys(MODELS, 70))
    for _ in range(3):
        assert client.post(f"/p/{token}/answer", data=form).status_code == 303
    rows = _rows(study)
    assert len(rows) == len(shown.items)
    with db.connect(study / db.DATABASE) as con:
        assert con.execute("SELECT COUNT(*) FROM submissions").fetchone()[0] == 1
    # finished: nothing more is accepted, not even a replay of the last page
    ratings = {a: dict.fromkeys(MODELS, 70) for a in AUDIOS}
    _answer_all(client, token, ratings, dict.fromkeys(AUDIOS, "lstm"))
    finished = _rows(study)
    assert len({(r["trial"]) for r in finished}) == 4
    assert client.post(f"/p/{token}/answer", data=form).status_code == 409
    assert _rows(study) == finished
    assert "Thank you" in client.get(f"/p/{token}/trial").get_data(as_text=True)


# Two participants' answers (rating 0–100 per model and audio; the model preferred on A/B).
RATINGS = {
    1: {
        AUDIOS[0]: {"mlp": 60, "lstm": 70, "ground-truth": 90, "anchor": 10},
        AUDIOS[1]: {"mlp": 50, "lstm": 65, "ground-truth": 95, "anchor": 20},
    },
    2: {
        AUDIOS[0]: {"mlp": 40, "lstm": 62, "ground-truth": 85, "anchor": 15},
        AUDIOS[1]: {"mlp": 55, "lstm": 58, "ground-truth": 100, "anchor": 5},
    },
}
PREFER = {1: {AUDIOS[0]: "lstm", AUDIOS[1]: "lstm"}, 2: {AUDIOS[0]: "lstm", AUDIOS[1]: "mlp"}}


def test_two_participants_give_the_hand_computed_analysis(client: FlaskClient, study: Path) -> None:
    for n in (1, 2):
        _answer_all(client, _join(client), RATINGS[n], PREFER[n])
    result = analyse(study)
    assert result.participants == 2
    mlp = next(r for r in result.ratings if r["condition"] == "mlp")
    # mlp: 60, 50, 40, 55 → mean 51.25; squared deviations 76.5625 + 1.5625 + 126.5625 +
    # 14.0625 = 218.75, s² = 218.75 / 3; t(0.975, 3) = 3.182446 (table) → ± 13.588
    half = 3.182446305 * (218.75 / 3) ** 0.5 / 2
    assert (mlp["n"], mlp["mean"]) == (4, 51.25)
    assert mlp["ci_low"] == pytest.approx(51.25 - half) and half == pytest.approx(13.588, abs=1e-3)
    assert mlp["ci_high"] == pytest.approx(51.25 + half)
    means = {r["condition"]: r["mean"] for r in result.ratings}
    assert means == {"ground-truth": 92.5, "lstm": 63.75, "anchor": 12.5, "mlp": 51.25}
    # lstm − mlp on each page: 10, 15, 22, 3 — all positive: W = 0, exact p = 2 / 2⁴
    test = next(t for t in result.tests if (t["a"], t["b"]) == ("lstm", "mlp"))
    assert (test["n"], test["test"], test["statistic"]) == (4, "wilcoxon", 0.0)
    assert test["p"] == pytest.approx(0.125) and test["mean_diff"] == 12.5
    assert len(result.tests) == 6  # every pair of the four conditions
    # A/B: lstm preferred 3 of 4 times; two-sided binomial p = (1 + 4 + 4 + 1) / 16
    (pref,) = result.preferences
    assert (pref["a"], pref["b"], pref["n"], pref["wins_a"]) == ("lstm", "mlp", 4, 3)
    assert pref["p"] == pytest.approx(0.625)
    assert result.plot is not None and result.plot.stat().st_size > 10_000
    # the export has every answer with its model, parsed back
    operator = (study / OPERATOR_TOKEN).read_text().strip()
    text = client.get("/export.csv", headers={"Authorization": f"Bearer {operator}"}).get_data(
        as_text=True
    )
    rows = list(csv.DictReader(io.StringIO(text)))
    assert len(rows) == 2 * (2 * 4 + 2 * 2)
    ratings = [int(r["rating"]) for r in rows if r["model"] == "mlp" and r["kind"] == "mushra"]
    assert sorted(ratings) == [40, 50, 55, 60]


def test_a_form_posted_from_another_site_is_refused(client: FlaskClient, study: Path) -> None:
    for other in ({"Origin": "http://elsewhere.example"}, {"Sec-Fetch-Site": "cross-site"}):
        assert client.post("/start", data={"consent": "yes"}, headers=other).status_code == 403
    same = {"Origin": "http://localhost"}  # the test client's own host
    assert client.post("/start", data={"consent": "yes"}, headers=same).status_code == 303
    with db.connect(study / db.DATABASE) as con:
        assert con.execute("SELECT COUNT(*) FROM participants").fetchone()[0] == 1


def test_speech_without_ground_truth_is_rated_without_a_reference(study: Path) -> None:
    """An --audio source has no ground truth: its rating page shows no labelled reference."""
    truth = IDS[(AUDIOS[1], "ground-truth")]
    manifest = json.loads((study / "stimuli.json").read_text())
    for group in manifest["groups"]:
        group["videos"] = [v for v in group["videos"] if v["id"] != truth]
    (study / "stimuli.json").write_text(json.dumps(manifest))
    design = load_design(study)
    mushra = design.trials[f"mushra-{AUDIOS[1]}"]
    assert mushra.reference is None and len(mushra.stimuli) == 3
    client = create_app(study).test_client()
    token = _join(client)
    while (shown := _shown(client, token)) is not None and shown.trial != mushra.id:
        client.post(f"/p/{token}/answer", data=_form(shown, dict.fromkeys(MODELS, 50)))
    assert shown is not None and len(shown.items) == 3
    assert "Reference" not in client.get(f"/p/{token}/trial").get_data(as_text=True)
