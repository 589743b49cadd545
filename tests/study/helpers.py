"""Reading the study's pages as a participant would (the trial shown, its videos in order)."""

from __future__ import annotations

import re
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from gesturebank.cli.study import make_server


@dataclass(frozen=True)
class Shown:
    trial: str
    kind: str  # "ab" or "mushra"
    items: tuple[str, ...]  # stimulus ids in display order (the labelled reference left out)
    step: int
    of: int


def shown_trial(page: str) -> Shown | None:
    """The trial a page shows, or None on the thank-you page."""
    found = re.search(r"name='trial' value='([^']+)'", page)
    if found is None:
        return None
    body = (
        page.split("<div class='ref'>", 1)[-1].split("</div>", 1)[-1]
        if "class='ref'" in page
        else page
    )
    items = tuple(re.findall(r"/video/([^'\"]+)['\"]", body))
    step, of = map(int, re.search(r"Page (\d+) of (\d+)", page).groups())  # type: ignore[union-attr]
    kind = "ab" if "name='choice'" in page else "mushra"
    return Shown(found.group(1), kind, items, step, of)


@contextmanager
def serving(study: Path, allow: Sequence[str]) -> Iterator[int]:
    """The study's real server on 127.0.0.1 (a free port, yielded), answering `allow` too."""
    httpd = make_server(study, host="127.0.0.1", port=0, allow_hosts=allow)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield httpd.server_port
    finally:
        httpd.shutdown()
        httpd.server_close()
        thread.join()
