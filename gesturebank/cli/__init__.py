"""The `gesturebank` command line (and its `build-dataset` shortcut): the app layer.

Each command's glue sits in a module of this package by command group (`build`, `qc`,
`calibrate`, `train`, `robot`, `export`, `study`, `render`, `clips`, `info`, `cache`); this module
assembles them, in the order `gesturebank --help` lists them. The stages never import it.

Exit codes: 0 ok; 1 some takes failed (the summary says which and why) or the robot failed;
2 usage, config or input error (a full disk, a dataset another process is writing);
130 interrupted (Ctrl-C), 143 build-dataset stopped by SIGTERM.
"""

from __future__ import annotations

import logging
import warnings
from typing import Annotated

import typer

from gesturebank.cli import (
    build,
    cache,
    calibrate,
    clips,
    export,
    info,
    qc,
    render,
    robot,
    study,
    train,
)
from gesturebank.cli.build import build_dataset_main
from gesturebank.cli.terminal import missing_extras
from gesturebank.errors import GesturebankDeprecationWarning

# The user of a command sees gesturebank's deprecations (an old config key and its new name);
# Python would show them only if __main__ raised them. Importing any command module runs this.
warnings.simplefilter("default", GesturebankDeprecationWarning)

__all__ = ["app", "build_dataset_main", "main"]

app = typer.Typer(
    name="gesturebank",
    help="Turn videos of people speaking into speech-and-motion datasets for the Pepper robot, "
    "train compact speech-to-motion models, and replay them on the robot.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",  # reflows docstring paragraphs to the terminal width
)


@app.callback()
def _main(
    verbose: Annotated[bool, typer.Option("--verbose", "-v", help="Log debug messages.")] = False,
) -> None:
    logging.basicConfig(
        level=logging.DEBUG if verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )


app.command()(info.info)
app.command("fetch-samples")(info.fetch_samples_cmd)
app.command("config")(info.config_cmd)
app.command("train")(train.train_cmd)
app.command()(train.evaluate)
app.command()(train.compare)
app.command()(train.synthesize)
app.command()(robot.replay)
app.command()(clips.preview)
app.command()(clips.clips)
app.command()(robot.live)
app.command("build-dataset")(build.build_dataset)
app.command("qc")(qc.qc_cmd)
app.command()(calibrate.calibrate)
app.command()(export.export)
app.command()(study.stimuli)
app.command()(render.render)
app.add_typer(study.study_app, name="study")
app.add_typer(cache.cache_app, name="cache")


def main() -> None:
    with missing_extras():
        app()
