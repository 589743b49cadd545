"""The QC dashboard: pages exist, say why a take was rejected, and load offline in Chromium."""

from __future__ import annotations

import base64
import json
import os
import select
import shutil
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import pytest
from qc_data import synthetic_take, write_synthetic_dataset

from gesturebank.qc.corrupt import corrupt, rederive
from gesturebank.qc.dashboard import qc_command

CHROMIUM = "/usr/bin/chromium"


@pytest.fixture(scope="module")
def synthetic_dashboard(tmp_path_factory: pytest.TempPathFactory) -> Path:
    takes = {f"subj{i}_take": synthetic_take(seed=i) for i in range(5)}
    takes["bad_take"] = rederive(corrupt(takes["subj0_take"], "swap", 2, seed=1))
    out = write_synthetic_dataset(tmp_path_factory.mktemp("dash"), takes)
    qc_command(out)
    return out


def test_pages_are_written(synthetic_dashboard: Path) -> None:
    qc = synthetic_dashboard / "qc"
    index = (qc / "index.html").read_text()
    assert "class='sortable'" in index and "Jerkiness per take" in index
    for i in range(5):
        assert f"takes/subj{i}_take.html" in index
        assert (qc / "takes" / f"subj{i}_take.html").is_file()
    assert "http://" not in index and "https://" not in index  # nothing to fetch


def test_a_rejected_take_page_shows_why(synthetic_dashboard: Path) -> None:
    page = (synthetic_dashboard / "qc" / "takes" / "bad_take.html").read_text()
    assert "QC status: <span class='status'>rejected</span>" in page
    reasons = page.split("<ul class='reasons'>")[1].split("</ul>")[0]
    assert "left/right arms swapped" in reasons
    good = (synthetic_dashboard / "qc" / "takes" / "subj1_take.html").read_text()
    assert "<span class='status'>accepted</span>" in good and "class='reasons'" not in good
    assert "blank canvas (no video)" in good


# --------------------------------------------------------------------------------------------------
# Headless Chromium through the DevTools protocol on a pipe (no websocket client needed)


class Browser:
    """Chromium with --remote-debugging-pipe: commands on fd 3, replies on fd 4, NUL-separated."""

    def __init__(self, profile: str) -> None:
        self._to_r, self._to_w = os.pipe()
        self._from_r, self._from_w = os.pipe()
        to_r, from_w = self._to_r, self._from_w

        def fds() -> None:
            os.dup2(to_r, 3)
            os.dup2(from_w, 4)

        args = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu"]
        args += ["--disable-background-networking", "--disable-component-update"]
        args += ["--disable-sync", "--no-first-run", f"--user-data-dir={profile}"]
        args += ["--remote-debugging-pipe", "--window-size=1400,1000", "about:blank"]
        self.proc = subprocess.Popen(
            args,
            pass_fds=sorted({3, 4, to_r, from_w}),
            preexec_fn=fds,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        os.close(to_r)
        os.close(from_w)
        self._buf = b""
        self._id = 0
        self.events: list[dict[str, Any]] = []

    def _recv(self, deadline: float) -> dict[str, Any]:
        while b"\0" not in self._buf:
            ready, _, _ = select.select(
                [self._from_r], [], [], max(0.0, deadline - time.monotonic())
            )
            if not ready:
                raise TimeoutError("no reply from Chromium")
            chunk = os.read(self._from_r, 1 << 20)
            if not chunk:
                raise EOFError("Chromium closed the pipe")
            self._buf += chunk
        msg, _, self._buf = self._buf.partition(b"\0")
        return json.loads(msg)

    def call(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        self._id += 1
        msg: dict[str, Any] = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._to_w, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + 60
        while True:
            reply = self._recv(deadline)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]
            self.events.append(reply)

    def open(self, url: str, screenshot: Path) -> list[dict[str, Any]]:
        """Load `url` in the first tab, save a full-page PNG; returns the events seen."""
        self.events = []
        targets = self.call("Target.getTargets")["targetInfos"]
        page = next(t for t in targets if t["type"] == "page")
        attach = {"targetId": page["targetId"], "flatten": True}
        session = self.call("Target.attachToTarget", attach)["sessionId"]
        for domain in ("Runtime", "Log", "Network", "Page"):
            self.call(f"{domain}.enable", session=session)
        self.call("Page.navigate", {"url": url}, session=session)
        deadline = time.monotonic() + 60
        while not any(e.get("method") == "Page.loadEventFired" for e in self.events):
            self.events.append(self._recv(deadline))
        shot = self.call(
            "Page.captureScreenshot",
            {"format": "png", "captureBeyondViewport": True},
            session=session,
        )
        screenshot.write_bytes(base64.b64decode(shot["data"]))
        self.call("Target.detachFromTarget", {"sessionId": session})
        return self.events

    def close(self) -> None:
        try:
            self.call("Browser.close")
        except (EOFError, TimeoutError, RuntimeError, OSError):
            pass
        os.close(self._to_w)
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self._from_r)


def _problems(events: list[dict[str, Any]], folder: Path) -> list[str]:
    """Console errors, exceptions, and requests for anything but this folder's files / data:."""
    found = []
    for e in events:
        method, params = e.get("method"), e.get("params", {})
        if method == "Runtime.exceptionThrown":
            found.append(f"exception: {params['exceptionDetails'].get('text')}")
        elif method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "warning"):
            found.append(f"console {params['type']}: {params.get('args')}")
        elif method == "Log.entryAdded" and params["entry"]["level"] in ("error", "warning"):
            found.append(f"log: {params['entry'].get('text')}")
        elif method == "Network.requestWillBeSent":
            url = params["request"]["url"]
            if not (url.startswith("data:") or url.startswith(folder.as_uri())):
                found.append(f"request: {url}")
    return found


@pytest.mark.skipif(not Path(CHROMIUM).is_file(), reason="needs Debian's chromium")
def test_dashboard_of_real_takes_loads_offline_in_chromium(real_dataset: Path, artifacts: Path):
    out = real_dataset.parent / "dashboard-copy"
    shutil.copytree(real_dataset, out, dirs_exist_ok=True)
    index = qc_command(out)
    takes = sorted((out / "qc" / "takes").glob("*.html"))
    assert len(takes) == 3
    with tempfile.TemporaryDirectory() as profile:
        browser = Browser(profile)
        try:
            seen = browser.open(index.as_uri(), artifacts / "qc-dashboard-index.png")
            assert _problems(seen, out / "qc") == []
            requests = [e for e in seen if e.get("method") == "Network.requestWillBeSent"]
            assert any(r["params"]["request"]["url"] == index.as_uri() for r in requests)
            for page in takes:
                seen = browser.open(page.as_uri(), artifacts / f"qc-dashboard-{page.stem}.png")
                assert _problems(seen, out / "qc") == []
        finally:
            browser.close()
    assert (artifacts / "qc-dashboard-index.png").stat().st_size > 10_000
    # frames came from the real video (videos_dir in dataset.json), not the blank canvas
    assert "2D skeleton on the video" in takes[0].read_text()
