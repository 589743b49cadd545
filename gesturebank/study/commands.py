"""`gesturebank study serve` and `gesturebank study analyse`: what the command line runs."""

from __future__ import annotations

import ipaddress
import math
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from gesturebank.errors import InputError

DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8000  # loopback: strangers only if the operator says


def make_server(folder: Path, *, host: str, port: int) -> Any:
    """A threaded werkzeug server of the study in `folder` (port 0: a free one)."""
    from werkzeug.serving import make_server as werkzeug_server

    from gesturebank.study.app import create_app

    if not folder.is_dir():
        raise InputError(f"{folder}: no such study folder")
    return werkzeug_server(host, port, create_app(folder), threaded=True)


def _loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host == "localhost"


def serve_command(*, folder: Path, host: str, port: int, console: Console) -> None:
    """Serve until Ctrl-C, after printing the participants' address and the operator token."""
    from gesturebank.study.app import OPERATOR_TOKEN, operator_token

    server = make_server(folder, host=host, port=port)
    url = f"http://{host}:{server.server_port}/"
    console.print(f"participants: {url}", highlight=False, soft_wrap=True)
    token = operator_token(folder)
    console.print(
        f"operator token (also in {folder / OPERATOR_TOKEN}): {token}\n"
        f'export: curl -H "Authorization: Bearer {token}" {url}export.csv',
        highlight=False,
        soft_wrap=True,
    )
    if not _loopback(host):
        console.print(f"warning: listening on {host}, reachable from other machines")
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()


def _num(value: float, digits: int = 1) -> str:
    return "–" if not math.isfinite(value) else f"{value:.{digits}f}"


def _p(value: float) -> str:
    return "–" if not math.isfinite(value) else f"{value:.3g}"


def analyse_command(*, folder: Path, console: Console) -> None:
    """Print the rating, paired-test and A/B tables, and where the plot went."""
    from gesturebank.study.analyse import analyse

    result = analyse(folder)
    console.print(f"{result.participants} participants", highlight=False)
    for question in sorted({r["question"] for r in result.ratings}):
        table = Table(title=f"{question}: ratings 0–100")
        for col in ("condition", "n", "mean", "95 % CI"):
            table.add_column(col)
        for r in (r for r in result.ratings if r["question"] == question):
            ci = f"{_num(r['ci_low'])} – {_num(r['ci_high'])}"
            table.add_row(r["condition"], str(r["n"]), _num(r["mean"]), ci)
        console.print(table)
        tests = Table(title=f"{question}: paired tests")
        for col in ("a", "b", "n", "mean a − b", "test", "statistic", "p"):
            tests.add_column(col)
        for t in (t for t in result.tests if t["question"] == question):
            tests.add_row(
                t["a"],
                t["b"],
                str(t["n"]),
                _num(t["mean_diff"]),
                t["test"],
                _num(t["statistic"], 2),
                _p(t["p"]),
            )
        console.print(tests)
    if result.preferences:
        table = Table(title="A/B preferences (binomial test against 50 %)")
        for col in ("a", "b", "n", "prefer a", "p"):
            table.add_column(col)
        for p in result.preferences:
            share = f"{p['wins_a']}/{p['n']} ({100 * p['share_a']:.0f} %)"
            table.add_row(p["a"], p["b"], str(p["n"]), share, _p(p["p"]))
        console.print(table)
    if result.plot is not None:
        console.print(f"plot written to {result.plot}", highlight=False, soft_wrap=True)
