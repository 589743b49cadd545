"""In real headless Chromium: the consent page as design.toml writes it, poster frames on every
video of a trial page, and the Host allow-list against a DNS-rebinding name (Chromium resolves
`rebind.test` to 127.0.0.1, as an attacker's DNS would)."""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from gesturebank.testing.browser import CHROMIUM, Browser, Tab
from tests.study.helpers import serving
from tests.study.test_browser import _navigating, _until
from tests.study.test_ethics import DESIGN

REBIND = "rebind.test"


@pytest.fixture()
def chromium() -> Iterator[Browser]:
    if not Path(CHROMIUM).is_file():
        pytest.skip("needs Debian's chromium")
    with tempfile.TemporaryDirectory() as profile:
        b = Browser(profile, [f"--host-resolver-rules=MAP {REBIND} 127.0.0.1"])
        try:
            yield b
        finally:
            b.close()


def _text(tab: Tab, element: str) -> str:
    return str(tab.eval(f"document.getElementById('{element}').textContent"))


def test_consent_page_in_chromium(study: Path, chromium: Browser, artifacts: Path) -> None:
    (study / "design.toml").write_text(DESIGN)
    with serving(study, []) as port:
        tab = chromium.open(f"http://127.0.0.1:{port}/")
        assert _text(tab, "title") == "Gestures of a talking robot"
        assert _text(tab, "researcher") == "Dr Ada Example, Robotics Lab, Example University"
        assert _text(tab, "contact") == "ada@example.org"
        assert _text(tab, "ethics") == "ERB-2026-042 <approved>"
        assert _text(tab, "data-use") == "Answers are kept for five years, then deleted."
        assert (_text(tab, "pages"), _text(tab, "minutes")) == ("4", "5")
        tab.screenshot(artifacts / "study-consent-page.png")
        tab.click("#agree")
        _navigating(tab, lambda: tab.click("#start"))
        assert "There are 4 pages" in tab.eval("document.body.textContent")
        tab.close()


def test_every_video_shows_its_poster_in_chromium(
    study: Path, chromium: Browser, artifacts: Path
) -> None:
    with serving(study, []) as port:
        tab = chromium.open(f"http://127.0.0.1:{port}/")
        tab.click("#agree")
        _navigating(tab, lambda: tab.click("#start"))
        _navigating(tab, lambda: tab.click("#begin"))
        videos = tab.eval("document.querySelectorAll('video').length")
        assert videos >= 2
        posters = tab.eval(
            "Array.from(document.querySelectorAll('video')).map(function (v) {"
            " return v.getAttribute('poster'); })"
        )
        assert all(p and "/poster/" in p for p in posters), posters
        # the browser fetches and decodes every poster (a JPEG within the page's own policy)
        tab.eval(
            "window.__posters = Array.from(document.querySelectorAll('video')).map("
            "function (v) { var i = new Image(); i.src = v.poster; return i; })"
        )
        _until(tab, "window.__posters.every(function (i) { return i.complete; })")
        sizes = tab.eval(
            "window.__posters.map(function (i) { return [i.naturalWidth, i.naturalHeight]; })"
        )
        assert sizes == [[160, 120]] * videos
        tab.screenshot(artifacts / "study-posters.png")
        problems = [
            e["params"]
            for e in chromium.events
            if e.get("method") in ("Runtime.exceptionThrown", "Log.entryAdded")
            and e["params"].get("entry", {}).get("level", "error") == "error"
        ]
        assert problems == []  # no CSP violation either
        tab.close()


def _document_status(browser: Browser) -> int:
    for e in browser.events:
        if e.get("method") == "Network.responseReceived" and e["params"]["type"] == "Document":
            return int(e["params"]["response"]["status"])
    raise AssertionError("no document response")


def test_a_rebound_name_is_refused_unless_allowed(study: Path, chromium: Browser) -> None:
    with serving(study, []) as port:
        tab = chromium.open(f"http://{REBIND}:{port}/")
        assert _document_status(chromium) == 403
        assert tab.eval("document.getElementById('consent')") is None
        tab.close()
    with serving(study, [REBIND]) as port:
        tab = chromium.open(f"http://{REBIND}:{port}/")
        assert _document_status(chromium) == 200
        tab.click("#agree")
        _navigating(tab, lambda: tab.click("#start"))
        assert tab.eval("location.host") == f"{REBIND}:{port}"
        assert "There are 4 pages" in tab.eval("document.body.textContent")
        tab.close()
