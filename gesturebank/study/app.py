"""The study's web app (Flask): consent → instructions → trials → thanks, for strangers.

Safety: a participant exists only once they have consented, and is known by an unguessable
token in their URL (`/p/<token>/…`) that opens only their own order and answers; the export and
the key need the operator token (`Authorization: Bearer …`, stored 0600 in the study folder).
Every field is checked against the participant's stored trial (known ids, ratings 0–100
integers, bounded comment); anything else is a 4xx that changes nothing. Pages carry their CSS
and JS inline under a nonce and a Content-Security-Policy that lets them load nothing but this
server's videos and posters. A request whose Host header names none of the allowed hosts (the
address served on, `--allow-host`) gets a 403: a page on another site that rebinds its DNS name
to this server (DNS rebinding) cannot use it, as its requests carry its own name.
"""

from __future__ import annotations

import csv
import io
import json
import os
import secrets
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from flask import Flask, Response, abort, g, redirect, request, send_from_directory

from gesturebank.study import db
from gesturebank.study.design import KEY, Design, load_design, participant_order
from gesturebank.study.pages import (
    ab_page,
    consent_page,
    done_page,
    instructions_page,
    mushra_page,
)
from gesturebank.study.posters import ensure_posters, poster_path

OPERATOR_TOKEN = "operator-token"
MAX_COMMENT = 500  # characters of a trial's free-text comment
Row = tuple[str, str, int | None, int | None]  # question, stimulus, rating, chosen
MAX_FORM_BYTES = 64 * 1024  # a whole submitted form; a trial's sliders need far less
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")  # names of this machine only: no rebinding


def host_name(header: str) -> str | None:
    """The name in a Host header, without port, lower case; None when malformed."""
    text = header.strip().lower()
    if text.startswith("["):  # [v6 address]:port
        name, sep, rest = text[1:].partition("]")
        ok = sep and (not rest or (rest[0] == ":" and rest[1:].isdigit()))
        return name if ok and name else None
    name, _, port = text.partition(":")
    if not name or (port and not port.isdigit()) or any(c in name for c in "/@ \t"):
        return None
    return name.rstrip(".")


def operator_token(folder: Path) -> str:
    """The study's operator token: read from the folder, or made and stored there (0600)."""
    path = folder / OPERATOR_TOKEN
    if path.is_file():
        path.chmod(0o600)  # in case it was copied with looser permissions
        return path.read_text(encoding="utf-8").strip()
    token = secrets.token_urlsafe(32)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(token + "\n")
    return token


def create_app(folder: Path, *, allowed_hosts: Collection[str] = LOOPBACK_HOSTS) -> Flask:
    """The app serving the study in `folder` (its design read once, now, and the videos'
    posters made where missing). `allowed_hosts`: the names the Host header may carry."""
    design = load_design(folder)
    ensure_posters(folder, {sid: s.file for sid, s in design.stimuli.items()})
    allowed = {h.strip().lower().strip("[]").rstrip(".") for h in allowed_hosts}
    operator = operator_token(folder)
    database = folder / db.DATABASE
    with db.connect(database):
        pass  # the schema exists before the first request
    app = Flask(__name__)
    app.config["MAX_CONTENT_LENGTH"] = MAX_FORM_BYTES

    @contextmanager
    def connection() -> Iterator[Any]:
        with db.connect(database) as con:
            yield con

    @app.before_request
    def _nonce() -> None:
        g.nonce = secrets.token_urlsafe(16)
        name = host_name(request.headers.get("Host", ""))
        if name is None:
            abort(400, "bad Host header")
        if name not in allowed:
            abort(403, f"this study is not served as {name!r}")
        if request.method == "POST" and _cross_site(request.headers):
            abort(403)  # a form posted from another site

    @app.after_request
    def _headers(resp: Response) -> Response:
        nonce = g.get("nonce", "")
        resp.headers["Content-Security-Policy"] = (
            f"default-src 'none'; style-src 'nonce-{nonce}'; script-src 'nonce-{nonce}'; "
            "media-src 'self'; img-src 'self'; form-action 'self'; base-uri 'none'; "
            "frame-ancestors 'none'"
        )
        resp.headers["X-Content-Type-Options"] = "nosniff"
        resp.headers["Referrer-Policy"] = "no-referrer"  # the token is in the URL
        resp.headers["Cache-Control"] = "no-store"
        return resp

    def page(body: str) -> Response:
        return Response(body.replace("{nonce}", g.nonce), mimetype="text/html")

    def me(token: str) -> dict[str, Any]:
        with connection() as con:
            found = db.participant(con, token)
        if found is None:
            abort(404)
        return found

    def _operator() -> None:
        given = request.headers.get("Authorization", "").removeprefix("Bearer ").strip()
        if not secrets.compare_digest(given.encode(), operator.encode()):
            abort(403)

    @app.get("/")
    def consent() -> Response:
        pages, minutes = len(design.trials), design.estimated_minutes()
        return page(consent_page(about=design.about, pages=pages, minutes=minutes))

    @app.get("/favicon.ico")
    def favicon() -> Response:
        return Response(status=204)  # browsers ask; there is none

    @app.post("/start")
    def start() -> Any:
        if request.form.get("consent") != "yes":
            abort(400, "consent is required")
        with connection() as con:
            new = db.add_participant(
                con,
                order_for=lambda seed, number: participant_order(
                    design=design, seed=seed, number=number
                ),
            )
        return redirect(f"/p/{new['token']}/", code=303)

    @app.get("/p/<token>/")
    def instructions(token: str) -> Response:
        who = me(token)
        return page(instructions_page(token=token, trials=len(who["order"])))

    @app.get("/p/<token>/trial")
    def trial(token: str) -> Any:
        who = me(token)
        with connection() as con:
            done = db.submitted(con, who["number"])
        left = [t for t in who["order"] if t["trial"] not in done]
        if not left or who["finished_at"]:
            return page(done_page())
        step, shown = len(who["order"]) - len(left) + 1, left[0]
        kind = design.trials[shown["trial"]].kind
        args = {"token": token, "shown": shown, "step": step, "of": len(who["order"])}
        if kind == "ab":
            return page(ab_page(**args, question=design.ab_question))
        reference = design.trials[shown["trial"]].reference
        return page(mushra_page(**args, reference=reference, questions=design.mushra_questions))

    @app.post("/p/<token>/answer")
    def answer(token: str) -> Any:
        who = me(token)
        shown = next((t for t in who["order"] if t["trial"] == request.form.get("trial")), None)
        if shown is None:
            abort(400, "unknown trial")
        rows = _rows(design, shown, request.form)
        comment = request.form.get("comment", "")
        if len(comment) > MAX_COMMENT:
            abort(400, "comment too long")
        with connection() as con:
            try:
                db.save_answers(
                    con,
                    number=who["number"],
                    trial=shown["trial"],
                    rows=rows,
                    comment=comment,
                    trials=len(who["order"]),
                )
            except db.Finished:
                abort(409, "you have finished the study")
        return redirect(f"/p/{token}/trial", code=303)

    @app.get("/p/<token>/answers")
    def answers(token: str) -> Response:
        who = me(token)
        with connection() as con:
            rows = db.own_answers(con, who["number"])
        return Response(json.dumps({"answers": rows}), mimetype="application/json")

    @app.get("/p/<token>/video/<stimulus>")
    def video(token: str, stimulus: str) -> Response:
        me(token)
        if stimulus not in design.stimuli:
            abort(404)
        return send_from_directory(folder, design.stimuli[stimulus].file, conditional=True)

    @app.get("/p/<token>/poster/<stimulus>")
    def poster(token: str, stimulus: str) -> Response:
        me(token)
        if stimulus not in design.stimuli:
            abort(404)
        path = poster_path(folder, stimulus)
        return send_from_directory(path.parent, path.name, mimetype="image/jpeg")

    @app.get("/export.csv")
    def export() -> Response:
        _operator()
        with connection() as con:
            rows = db.all_answers(con)
        return Response(export_csv(design, rows), mimetype="text/csv")

    @app.get("/key.json")
    def key() -> Response:
        _operator()
        return Response((folder / KEY).read_text(encoding="utf-8"), mimetype="application/json")

    return app


def _cross_site(headers: Any) -> bool:
    """Whether the browser says the request comes from another site. (With no-referrer,
    Chromium sends `Origin: null` on our own forms, so Sec-Fetch-Site decides then.)"""
    if headers.get("Sec-Fetch-Site") in ("cross-site", "same-site"):
        return True
    origin = headers.get("Origin")
    return bool(origin) and origin != "null" and origin != request.host_url.rstrip("/")


def _ints(text: str | None) -> int:
    """A rating: the decimal digits of an integer 0–100 and nothing else."""
    if text is None or not text.isascii() or not text.isdigit() or len(text) > 3:
        abort(400, "a rating must be an integer 0–100")
    value = int(text)
    if not 0 <= value <= 100:
        abort(400, "a rating must be an integer 0–100")
    return value


def _rows(design: Design, shown: dict[str, Any], form: Any) -> list[Row]:
    """The answer rows of one submitted trial form, or a 400: A/B takes `choice` ∈ {0, 1}
    (the side shown), MUSHRA `r-<question>-<k>` for every question and shown stimulus k."""
    items, kind = shown["items"], design.trials[shown["trial"]].kind
    expected = {"trial", "comment"}
    rows: list[Row] = []
    if kind == "ab":
        expected.add("choice")
        side = form.get("choice")
        if side not in ("0", "1"):
            abort(400, "choose one of the two videos")
        picked = int(side)
        rows += [("preference", sid, None, int(k == picked)) for k, sid in enumerate(items)]
    else:
        for q in design.mushra_questions:
            for k, sid in enumerate(items):
                name = f"r-{q}-{k}"
                expected.add(name)
                rows.append((q, sid, _ints(form.get(name)), None))
    if set(form) - expected:
        abort(400, "unknown fields")
    return rows


def export_csv(design: Design, rows: list[dict[str, Any]]) -> str:
    """The answers as CSV, one row per answer, with the key's model and audio beside it."""
    out = io.StringIO()
    fields = ["participant", "trial", "kind", "question", "stimulus", "model", "audio"]
    fields += ["rating", "chosen", "comment", "submitted_at", "finished"]
    writer = csv.DictWriter(out, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    for r in rows:
        stim = design.stimuli[r["stimulus"]]
        kind = design.trials[r["trial"]].kind
        row = {**r, "kind": kind, "model": stim.model, "audio": stim.audio}
        writer.writerow({k: _cell(v) for k, v in row.items()})
    return out.getvalue()


def _cell(value: Any) -> Any:
    """A participant's text as a spreadsheet shows it, not as a formula."""
    if isinstance(value, str) and value[:1] in ("=", "+", "-", "@", "\t", "\r"):
        return "'" + value
    return value
