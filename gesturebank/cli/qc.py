"""`gesturebank qc`: judge a dataset's clips again and write its dashboard."""

from __future__ import annotations

from gesturebank.cli.build import print_summary
from gesturebank.cli.options import ConfigOption, DatasetArg, SetOption, resolve_config
from gesturebank.cli.terminal import out, user_errors
from gesturebank.errors import InputError


def qc_cmd(
    out_dir: DatasetArg, *, config_file: ConfigOption = None, sets: SetOption = None
) -> None:
    """Re-run the quality checks on a dataset and write its dashboard.

    Measures every clip again from its arrays and judges it (jerk, unseen head or arms, bone
    lengths, a robot frozen at a limit, jitter, swaps, spikes, static or frozen poses, framing,
    and the invariants every written clip must hold: joint speed, jerk not above the raw jerk,
    finite where mask, inside the limits, angles01, audio) against the [qc] thresholds and
    against each other, updates
    the records, manifest, dataset.json and splits, and writes OUT_DIR/qc/index.html with a page
    per take. The dataset's own configuration is the base: only what --config and --set change
    differs (the [qc] and [splits] sections; the clips stay as built).
    """
    from gesturebank.app.build import BuildSummary
    from gesturebank.datasets import store
    from gesturebank.datasets.digest import CONTENT_SECTIONS
    from gesturebank.datasets.lock import dataset_lock
    from gesturebank.datasets.refresh import refresh
    from gesturebank.fileio import output_errors
    from gesturebank.report import write_dashboard

    with user_errors():
        built = store.read_dataset_json(out_dir).config
        config = resolve_config(config_file=config_file, sets=sets, flags={}, base=built)
        changed = [s for s in CONTENT_SECTIONS if config.digest(s) != built.digest(s)]
        if changed:
            raise InputError(
                f"{out_dir}: `gesturebank qc` re-judges the clips as built; [{changed[0]}] "
                "changes what they contain: run build-dataset with it instead"
            )
        # one writer per dataset: not while a build or another qc writes it
        with dataset_lock(out_dir), output_errors(out_dir, "the QC results"):
            notes = refresh(out_dir, config, recheck=True)
            index = write_dashboard(out_dir)
        records = store.take_records(out_dir)
    summary = BuildSummary(out_dir, notes=list(notes), dashboard=index, takes=records)
    print_summary(out, summary, built=False)
