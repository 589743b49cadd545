"""`gesturebank stimuli`, `gesturebank study serve` and `gesturebank study analyse`: what the
command line runs (the stimuli are `study.stimuli`'s)."""

from __future__ import annotations

import ipaddress
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

import typer
from rich import box
from rich.console import Console
from rich.table import Table

from gesturebank.app import NARROW_COLUMNS
from gesturebank.cli.options import ConfigOption, ForceOption, SetOption, resolve_config
from gesturebank.cli.terminal import out, user_errors
from gesturebank.errors import InputError
from gesturebank.fileio import keep_existing

DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8000  # loopback: strangers only if the operator says


def allowed_hosts(host: str, extra: Sequence[str] = ()) -> list[str]:
    """The Host names the app answers: the address served on (with this machine's own names
    when that is loopback; none for a wildcard such as 0.0.0.0) and `extra` (`--allow-host`)."""
    from gesturebank.study.app import LOOPBACK_HOSTS

    names = list(LOOPBACK_HOSTS) if _loopback(host) else []
    if not _wildcard(host):
        names.append(host)
    return names + [h for h in extra if h]


def make_server(folder: Path, *, host: str, port: int, allow_hosts: Sequence[str] = ()) -> Any:
    """A threaded werkzeug server of the study in `folder` (port 0: a free one), answering
    requests for `allowed_hosts(host, allow_hosts)` only."""
    from werkzeug.serving import make_server as werkzeug_server

    from gesturebank.study.app import create_app

    if not folder.is_dir():
        raise InputError(f"{folder}: no such study folder")
    app = create_app(folder, allowed_hosts=allowed_hosts(host, allow_hosts))
    return werkzeug_server(host, port, app, threaded=True)


def _wildcard(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_unspecified
    except ValueError:
        return False


def _loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host == "localhost"


def serve_command(
    *, folder: Path, host: str, port: int, console: Console, allow_hosts: Sequence[str] = ()
) -> None:
    """Serve until Ctrl-C, after printing the participants' address and the operator token."""
    from gesturebank.study.app import OPERATOR_TOKEN, operator_token
    from gesturebank.study.design import DESIGN, read_design_file

    server = make_server(folder, host=host, port=port, allow_hosts=allow_hosts)
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
    if _wildcard(host) and not allow_hosts:
        console.print(
            f"warning: {host} is no name participants can use: give the address they type "
            "with --allow-host (other Host headers are refused)"
        )
    missing = read_design_file(folder / DESIGN).missing()
    if missing:
        console.print(
            f"note: {folder / DESIGN} gives no {', '.join(missing)}; the consent page "
            "goes without (an ethics board will ask for them)",
            highlight=False,
            soft_wrap=True,
        )
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


def analyse_command(*, folder: Path, console: Console, include_partial: bool = False) -> None:
    """Print the rating, paired-test and A/B tables, and where the plot went. A terminal
    narrower than `NARROW_COLUMNS`: tables without vertical rules, and each paired test and A/B
    pair on a line of its own (wrapped at words), so that 80 columns show every value whole."""
    from gesturebank.study.analyse import analyse

    result = analyse(folder, include_partial=include_partial)
    narrow = console.width < NARROW_COLUMNS
    used = "finished and partial" if include_partial else "finished only"
    console.print(
        f"participants: {result.finished} finished, {result.partial} partial (stopped "
        f"half-way), {result.no_answer} consented without answering; analysed: "
        f"{result.participants} ({used})",
        highlight=False,
        soft_wrap=not narrow,
    )
    for question in sorted({r["question"] for r in result.ratings}):
        table = _table(f"{question}: ratings 0–100", narrow)
        for col in ("condition", "n", "mean", "95 % CI (within 0–100)"):
            table.add_column(col)
        for r in (r for r in result.ratings if r["question"] == question):
            ci = f"{_num(r['ci_low'])} – {_num(r['ci_high'])}"
            table.add_row(r["condition"], str(r["n"]), _num(r["mean"]), ci)
        console.print(table)
        tests = [t for t in result.tests if t["question"] == question]
        if narrow:
            console.print(f"\n{question}: paired tests", highlight=False, style="italic")
            for t in tests:
                console.print(
                    f"  {t['a']} vs {t['b']}: n {t['n']}, mean a − b {_num(t['mean_diff'])}\n"
                    f"    {t['test']} statistic {_num(t['statistic'], 2)}, p {_p(t['p'])}, "
                    f"p (Holm) {_p(t['p_holm'])}",
                    highlight=False,
                )
            continue
        table = Table(title=f"{question}: paired tests")
        for col in ("a", "b", "n", "mean a − b", "test", "statistic", "p", "p (Holm)"):
            table.add_column(col)
        for t in tests:
            table.add_row(
                t["a"],
                t["b"],
                str(t["n"]),
                _num(t["mean_diff"]),
                t["test"],
                _num(t["statistic"], 2),
                _p(t["p"]),
                _p(t["p_holm"]),
            )
        console.print(table)
    if result.preferences and narrow:
        console.print(
            "\nA/B preferences (binomial test against 50 %)", highlight=False, style="italic"
        )
        for p in result.preferences:
            console.print(
                f"  {p['a']} vs {p['b']}: n {p['n']}, prefer {p['a']}\n"
                f"    {p['wins_a']}/{p['n']} ({100 * p['share_a']:.0f} %), p {_p(p['p'])}, "
                f"p (Holm) {_p(p['p_holm'])}",
                highlight=False,
            )
    elif result.preferences:
        table = Table(title="A/B preferences (binomial test against 50 %)")
        for col in ("a", "b", "n", "prefer a", "p", "p (Holm)"):
            table.add_column(col)
        for p in result.preferences:
            share = f"{p['wins_a']}/{p['n']} ({100 * p['share_a']:.0f} %)"
            table.add_row(p["a"], p["b"], str(p["n"]), share, _p(p["p"]), _p(p["p_holm"]))
        console.print(table)
    if result.plot is not None:
        console.print(f"plot written to {result.plot}", highlight=False, soft_wrap=True)


def _table(title: str, narrow: bool) -> Table:
    if narrow:  # no vertical rules
        return Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True)
    return Table(title=title)


def stimuli(
    model_dirs: Annotated[list[Path], typer.Argument(help="Model folders written by `train`.")],
    *,
    study_dir: Annotated[Path, typer.Option("--out", help="Study folder to write.")],
    audio: Annotated[
        list[Path] | None, typer.Option(help="Speech: an audio file (repeatable).")
    ] = None,
    clip: Annotated[
        list[str] | None,
        typer.Option(
            help="Speech of a dataset clip, DATASET_DIR:CLIP_ID, with its ground truth "
            "(repeatable)."
        ),
    ] = None,
    timelines: Annotated[
        list[Path] | None,
        typer.Option(
            help="Another system's motion: a folder of angle timelines, one per speech "
            "(<audio stem or clip id>.csv or .jsonl), shown as one more condition (repeatable)."
        ),
    ] = None,
    anchor: Annotated[
        Literal["mean-pose", "random-clip"], typer.Option(help="The anchor condition.")
    ] = "mean-pose",
    anchor_seed: Annotated[
        int, typer.Option(help="Picks the random-clip anchor and the videos' order.")
    ] = 0,
    config_file: ConfigOption = None,
    sets: SetOption = None,
    force: ForceOption = False,
) -> None:
    """Blind stimulus videos for a perceptual study: for each speech (--audio, --clip) one video
    per model and per --timelines folder, the ground truth (clips) and an anchor — same camera
    ([render]) and duration, audio muxed, named by random ids. STUDY/stimuli.json lists them
    without their conditions; STUDY/key.json says which is which (keep it from participants);
    STUDY/motion/ holds the angles each video shows.
    """
    from gesturebank.study.stimuli import stimuli_command

    with user_errors():
        keep_existing([study_dir], force=force)
        config = resolve_config(config_file=config_file, sets=sets, flags={})
        manifest = stimuli_command(
            model_dirs=model_dirs,
            out=study_dir,
            audios=audio or [],
            clips=clip or [],
            timelines=timelines or [],
            anchor=anchor,
            anchor_seed=anchor_seed,
            render=config.render,
            playback=config.playback,
            profile=config.robot.profile,
        )
    n = sum(len(g["videos"]) for g in manifest["groups"])
    out.print(f"{n} stimuli written to {study_dir}", highlight=False, soft_wrap=True)


study_app = typer.Typer(
    help="A perceptual study of rendered stimuli: serve it to participants, analyse the answers.",
    no_args_is_help=True,
)


StudyArg = Annotated[
    Path, typer.Argument(help="A study folder written by `gesturebank stimuli … --out`.")
]


@study_app.command("serve")
def study_serve(
    study_dir: StudyArg,
    *,
    host: Annotated[
        str, typer.Option(help="Address to listen on; another than 127.0.0.1 lets others in.")
    ] = DEFAULT_HOST,
    port: Annotated[int, typer.Option(min=0, max=65535, help="Port (0: a free one).")] = (
        DEFAULT_PORT
    ),
    allow_host: Annotated[
        list[str] | None,
        typer.Option(
            help="Another name participants reach the study by (repeatable); other Host "
            "headers than these and --host are refused (DNS rebinding)."
        ),
    ] = None,
) -> None:
    """Serve the study's web app: consent, instructions, A/B and MUSHRA-style rating pages in a
    random, counterbalanced order per participant, answers in STUDY_DIR/responses.sqlite.

    Prints the participants' address and the operator token that opens /export.csv and
    /key.json (stored, readable by you only, in STUDY_DIR/operator-token). Ctrl-C stops.
    """
    from gesturebank.cli.study import serve_command

    with user_errors():
        serve_command(
            folder=study_dir, host=host, port=port, console=out, allow_hosts=allow_host or []
        )


@study_app.command("analyse")
def study_analyse(
    study_dir: StudyArg,
    include_partial: Annotated[
        bool, typer.Option(help="Also analyse participants who stopped half-way.")
    ] = False,
) -> None:
    """Tables of the answers of participants who finished: mean rating per condition with 95 %
    confidence intervals (within the 0–100 scale), paired Wilcoxon signed-rank or t-tests per
    question and A/B shares with a binomial test, each with Holm-adjusted p beside the raw p;
    and a plot (STUDY_DIR/analysis/ratings.png)."""
    from gesturebank.cli.study import analyse_command

    with user_errors():
        analyse_command(folder=study_dir, console=out, include_partial=include_partial)
