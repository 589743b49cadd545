"""The study's SQLite database: participants (token, seed, stored order) and their answers.

Every write is one transaction; all SQL is parameterised. A trial's answers are keyed by
(participant, trial, question, stimulus), so a replayed submission replaces rows with equal ones
and nothing is ever stored twice; a finished participant can submit nothing more.
"""

from __future__ import annotations

import json
import secrets
import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

DATABASE = "responses.sqlite"

SCHEMA = """
CREATE TABLE IF NOT EXISTS participants (
    number INTEGER PRIMARY KEY AUTOINCREMENT,
    token TEXT NOT NULL UNIQUE,
    seed INTEGER NOT NULL,
    trial_order TEXT NOT NULL,
    consented_at TEXT NOT NULL,
    finished_at TEXT
);
CREATE TABLE IF NOT EXISTS submissions (
    participant INTEGER NOT NULL REFERENCES participants(number),
    trial TEXT NOT NULL,
    comment TEXT NOT NULL DEFAULT '',
    submitted_at TEXT NOT NULL,
    PRIMARY KEY (participant, trial)
);
CREATE TABLE IF NOT EXISTS answers (
    participant INTEGER NOT NULL REFERENCES participants(number),
    trial TEXT NOT NULL,
    question TEXT NOT NULL,
    stimulus TEXT NOT NULL,
    rating INTEGER CHECK (rating IS NULL OR rating BETWEEN 0 AND 100),
    chosen INTEGER CHECK (chosen IS NULL OR chosen IN (0, 1)),
    PRIMARY KEY (participant, trial, question, stimulus),
    FOREIGN KEY (participant, trial) REFERENCES submissions(participant, trial)
);
"""


class Finished(Exception):
    """The participant has finished: no more answers."""


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


@contextmanager
def connect(path: Path) -> Iterator[sqlite3.Connection]:
    """A connection whose `with con:` blocks are transactions; the schema exists."""
    con = sqlite3.connect(path, timeout=30, isolation_level=None)
    con.row_factory = sqlite3.Row
    try:
        con.execute("PRAGMA foreign_keys = ON")
        con.execute("PRAGMA journal_mode = WAL")  # readers (export) do not block the writer
        con.executescript(SCHEMA)
        yield con
    finally:
        con.close()


@contextmanager
def _transaction(con: sqlite3.Connection) -> Iterator[None]:
    con.execute("BEGIN IMMEDIATE")
    try:
        yield
    except BaseException:
        con.execute("ROLLBACK")
        raise
    con.execute("COMMIT")


def add_participant(con: sqlite3.Connection, *, order_for: Any) -> dict[str, Any]:
    """A new participant (who has consented): an unguessable token, a seed, and the trial
    order `order_for(seed=…, number=…)` gives, stored so that a reload resumes exactly."""
    token, seed = secrets.token_urlsafe(32), secrets.randbits(31)
    with _transaction(con):
        cur = con.execute(
            "INSERT INTO participants (token, seed, trial_order, consented_at)"
            " VALUES (?, ?, '', ?)",
            (token, seed, _now()),
        )
        number = int(cur.lastrowid or 0)
        order = order_for(seed=seed, number=number)
        con.execute(
            "UPDATE participants SET trial_order = ? WHERE number = ?", (json.dumps(order), number)
        )
    return {"number": number, "token": token, "seed": seed, "order": order, "finished_at": None}


def participant(con: sqlite3.Connection, token: str) -> dict[str, Any] | None:
    row = con.execute(
        "SELECT number, token, seed, trial_order, finished_at FROM participants WHERE token = ?",
        (token,),
    ).fetchone()
    if row is None:
        return None
    return {**dict(row), "order": json.loads(row["trial_order"])}


def submitted(con: sqlite3.Connection, number: int) -> set[str]:
    rows = con.execute("SELECT trial FROM submissions WHERE participant = ?", (number,))
    return {r["trial"] for r in rows}


def save_answers(
    con: sqlite3.Connection,
    *,
    number: int,
    trial: str,
    rows: list[tuple[str, str, int | None, int | None]],
    comment: str,
    trials: int,
) -> None:
    """Store one trial's answers, (question, stimulus, rating, chosen) each, replacing any
    earlier answers of this participant to this trial; once all their `trials` are answered
    the participant has finished (decided inside the transaction, so two tabs cannot race)."""
    with _transaction(con):
        done = con.execute(
            "SELECT finished_at FROM participants WHERE number = ?", (number,)
        ).fetchone()
        if done is None or done["finished_at"] is not None:
            raise Finished(f"participant {number} has finished")
        con.execute("DELETE FROM answers WHERE participant = ? AND trial = ?", (number, trial))
        con.execute(
            "INSERT INTO submissions (participant, trial, comment, submitted_at)"
            " VALUES (?, ?, ?, ?)"
            " ON CONFLICT (participant, trial) DO UPDATE SET comment = excluded.comment",
            (number, trial, comment, _now()),
        )
        con.executemany(
            "INSERT INTO answers (participant, trial, question, stimulus, rating, chosen)"
            " VALUES (?, ?, ?, ?, ?, ?)",
            [(number, trial, q, s, r, c) for q, s, r, c in rows],
        )
        (done,) = con.execute(
            "SELECT COUNT(*) FROM submissions WHERE participant = ?", (number,)
        ).fetchone()
        if done >= trials:
            con.execute(
                "UPDATE participants SET finished_at = ? WHERE number = ?", (_now(), number)
            )


def own_answers(con: sqlite3.Connection, number: int) -> list[dict[str, Any]]:
    rows = con.execute(
        "SELECT trial, question, stimulus, rating, chosen FROM answers WHERE participant = ?"
        " ORDER BY trial, question, stimulus",
        (number,),
    )
    return [dict(r) for r in rows]


def all_answers(con: sqlite3.Connection) -> list[dict[str, Any]]:
    """Every answer with its participant's number, whether they finished (0/1) and the trial's
    comment (for export)."""
    rows = con.execute(
        "SELECT a.participant, p.finished_at IS NOT NULL AS finished, a.trial, a.question,"
        " a.stimulus, a.rating, a.chosen, s.comment, s.submitted_at FROM answers a"
        " JOIN submissions s ON s.participant = a.participant AND s.trial = a.trial"
        " JOIN participants p ON p.number = a.participant"
        " ORDER BY a.participant, a.trial, a.question, a.stimulus"
    )
    return [dict(r) for r in rows]


def participant_counts(con: sqlite3.Connection) -> dict[str, int]:
    """Participants who finished, who answered some pages but not all (partial), and who
    consented and answered nothing."""
    (finished, partial, none) = con.execute(
        "SELECT COALESCE(SUM(finished_at IS NOT NULL), 0),"
        " COALESCE(SUM(finished_at IS NULL AND EXISTS"
        "  (SELECT 1 FROM submissions s WHERE s.participant = number)), 0),"
        " COALESCE(SUM(finished_at IS NULL AND NOT EXISTS"
        "  (SELECT 1 FROM submissions s WHERE s.participant = number)), 0)"
        " FROM participants"
    ).fetchone()
    return {"finished": int(finished), "partial": int(partial), "no_answer": int(none)}
