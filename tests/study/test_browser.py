"""A whole session in real headless Chromium against the served study: consent, instructions,
A/B and rating pages (sliders moved by mouse clicks), a reload half-way, the thank-you page;
then the SQLite rows and the analysis, and that no request left 127.0.0.1."""

from __future__ import annotations

import json
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from gesturebank.cli.study import make_server
from gesturebank.study import db
from gesturebank.study.analyse import analyse
from gesturebank.testing.browser import CHROMIUM, Browser, Tab
from tests.study.conftest import IDS

MODEL_OF = {sid: model for (_, model), sid in IDS.items()}
WAIT_S = 60  # a page load on a busy machine; only an upper bound, never asserted


@pytest.fixture()
def server(study: Path) -> Iterator[str]:
    httpd = make_server(study, host="127.0.0.1", port=0)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_port}"
    finally:
        httpd.shutdown()
        httpd.server_close()
        thread.join()


@pytest.fixture()
def browser() -> Iterator[Browser]:
    if not Path(CHROMIUM).is_file():
        pytest.skip("needs Debian's chromium")
    with tempfile.TemporaryDirectory() as profile:
        b = Browser(profile)
        try:
            yield b
        finally:
            b.close()


def _until(tab: Tab, expression: str) -> Any:
    """Poll `expression` until it is truthy (a navigation may be under way meanwhile)."""
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        try:
            value = tab.eval(expression)
        except (AssertionError, RuntimeError):  # the old page's context went away
            value = None
        if value:
            return value
        time.sleep(0.05)
    raise TimeoutError(f"page never satisfied: {expression}")


def _navigating(tab: Tab, action: Any) -> None:
    """Do `action` (a click that loads a page) and wait for the new page to be complete."""
    tab.eval("window.__old = true")
    action()
    _until(tab, "!window.__old && document.readyState === 'complete'")


def _click_at(tab: Tab, selector: str, fraction: float) -> None:
    """A real mouse click `fraction` of the way along the element (a slider's track)."""
    box = tab.eval(
        f"(function (e) {{ e.scrollIntoView({{block: 'center'}});"
        f" var r = e.getBoundingClientRect();"
        f" return [r.x + {fraction} * r.width, r.y + r.height / 2]; }})"
        f"(document.querySelector({json.dumps(selector)}))"
    )
    for kind in ("mousePressed", "mouseReleased"):
        event = {"type": kind, "x": box[0], "y": box[1], "button": "left", "clickCount": 1}
        tab.call("Input.dispatchMouseEvent", event)


def _page_state(tab: Tab) -> dict[str, Any]:
    return tab.eval(
        "({trial: document.querySelector('input[name=trial]').value,"
        " progress: document.getElementById('progress').textContent,"
        " videos: Array.from(document.querySelectorAll('.item video'))"
        ".map(function (v) { return v.getAttribute('src').split('/').pop(); }),"
        " sliders: Array.from(document.querySelectorAll('input[type=range]'))"
        ".map(function (s) { return s.id; }),"
        " disabled: document.getElementById('submit').disabled})"
    )


def _answer(tab: Tab, state: dict[str, Any]) -> dict[str, int]:
    """Answer the page shown: prefer lstm on A/B, or click each slider at its own place;
    returns what the page now holds (model → rating, or the preferred model → 1)."""
    assert state["disabled"]  # nothing chosen yet: the script keeps Next disabled
    if not state["sliders"]:
        side = [MODEL_OF[s] for s in state["videos"]].index("lstm")
        tab.click(f"#choice-{side}")
        _until(tab, "!document.getElementById('submit').disabled")
        return {"lstm": 1}
    given = {}
    for k, (slider, sid) in enumerate(zip(state["sliders"], state["videos"], strict=True)):
        _click_at(tab, f"#{slider}", 0.15 + 0.2 * k)
        value = int(tab.eval(f"document.getElementById('{slider}').value"))
        assert tab.eval(f"document.getElementById('{slider}-v').textContent") == str(value)
        given[MODEL_OF[sid]] = value
    assert not tab.eval("document.getElementById('submit').disabled")
    return given


def test_a_whole_session_in_chromium(
    study: Path, server: str, browser: Browser, artifacts: Path
) -> None:
    tab = browser.open(f"{server}/")
    assert "I have read the above" in tab.eval("document.body.textContent")
    tab.click("#start")  # not ticked: the browser does not send the form
    assert tab.eval("location.pathname") == "/"
    tab.click("#agree")
    _navigating(tab, lambda: tab.click("#start"))
    token = tab.eval("location.pathname").split("/")[2]
    assert "There are 4 pages" in tab.eval("document.body.textContent")
    _navigating(tab, lambda: tab.click("#begin"))

    answers: dict[str, dict[str, int]] = {}
    for step in range(1, 5):
        state = _page_state(tab)
        assert state["progress"] == f"Page {step} of 4"
        if step == 3:  # a reload half-way shows the same page, the same videos in the same order
            tab.call("Page.reload")
            _until(
                tab, "document.readyState === 'complete' && !!document.getElementById('progress')"
            )
            again = _page_state(tab)
            assert (again["trial"], again["videos"], again["progress"]) == (
                state["trial"],
                state["videos"],
                state["progress"],
            )
        answers[state["trial"]] = _answer(tab, state)
        kind = "rating" if state["sliders"] else "ab"
        tab.screenshot(artifacts / f"study-{kind}-page.png")
        _navigating(tab, lambda: tab.click("#submit"))
    assert tab.eval("document.getElementById('done').textContent") == "Thank you!"
    tab.close()

    # what the page showed is what the database holds
    with db.connect(study / db.DATABASE) as con:
        (who,) = [
            dict(r) for r in con.execute("SELECT number, token, finished_at FROM participants")
        ]
        rows = db.all_answers(con)
    assert who["token"] == token and who["finished_at"]
    for trial, given in answers.items():
        stored = [r for r in rows if r["trial"] == trial]
        if trial.startswith("ab-"):
            assert {MODEL_OF[r["stimulus"]]: r["chosen"] for r in stored}["lstm"] == 1
        else:
            assert {MODEL_OF[r["stimulus"]]: r["rating"] for r in stored} == given
    assert len(rows) == 2 * 4 + 2 * 2
    # and the analysis sees it: each condition rated twice (two sentences), its mean
    result = analyse(study)
    for r in result.ratings:
        mine = [g[r["condition"]] for t, g in answers.items() if t.startswith("mushra-")]
        assert (r["n"], r["mean"]) == (2, sum(mine) / 2)
    (pref,) = result.preferences
    assert (pref["a"], pref["wins_a"], pref["n"]) == ("lstm", 2, 2)

    # nothing but this server: every request, the videos' too (data: URLs are the browser's
    # own video-control icons, never fetched); no console error (CSP violations included)
    requests = [
        e["params"]["request"]["url"]
        for e in browser.events
        if e.get("method") == "Network.requestWillBeSent"
        and not e["params"]["request"]["url"].startswith("data:")
    ]
    assert requests and all(u.startswith(f"{server}/") for u in requests), requests
    assert any("/video/" in u for u in requests)
    problems = [
        e["params"]
        for e in browser.events
        if e.get("method") in ("Runtime.exceptionThrown", "Log.entryAdded")
        and e["params"].get("entry", {}).get("level", "error") == "error"
    ]
    assert problems == []
