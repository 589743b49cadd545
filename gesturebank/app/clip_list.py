"""`gesturebank clips` on the terminal: a dataset's clips (`datasets.listing.list_clips`) as a
rich table, or one block per clip on a narrow terminal."""

from __future__ import annotations

from rich import box
from rich.console import Group, RenderableType
from rich.padding import Padding
from rich.table import Table
from rich.text import Text

from gesturebank.datasets.listing import ClipRow

TABLE_MIN_COLUMNS = 120  # narrower terminals get one block per clip: reasons wrap whole


def clips_table(rows: list[ClipRow], *, title: str) -> Table:
    """The rows as a rich table: ids never cut, the span as start–end, status in colour. The
    take is the clip id before its `__cNNN` (its own column in `rows_csv`): a narrower table."""
    table = Table(title=title, title_justify="left", box=box.SIMPLE_HEAD, pad_edge=False)
    table.add_column("clip (take__cNNN)", no_wrap=True)
    table.add_column("subject", overflow="fold")
    table.add_column("start–end s", justify="right", no_wrap=True)
    table.add_column("s", justify="right", no_wrap=True)
    table.add_column("status", no_wrap=True)
    table.add_column("reasons", ratio=3)
    table.add_column("masked", ratio=2)
    colour = {"accepted": "green", "rejected": "red"}
    for r in rows:
        c = colour.get(r.status, "yellow")
        table.add_row(
            r.clip_id,
            r.subject,
            f"{r.start_s:.2f}–{r.end_s:.2f}",
            f"{r.seconds:.2f}",
            f"[{c}]{r.status}[/{c}]",
            "; ".join(r.reasons),
            r.masked_text(),
        )
    return table


def clips_blocks(rows: list[ClipRow], *, title: str) -> Group:
    """The rows for a narrow terminal: a clip's id, status, subject and span on one line, then
    its reasons and masked parts indented below, each wrapped as a whole sentence."""
    colour = {"accepted": "green", "rejected": "red"}
    parts: list[RenderableType] = [Text(title)]
    for r in rows:
        c = colour.get(r.status, "yellow")
        head = Text.assemble(
            (r.clip_id, "bold"),
            "  ",
            (r.status, c),
            f"  {r.subject}  {r.start_s:.2f}–{r.end_s:.2f} s ({r.seconds:.2f} s)",
        )
        parts.append(head)
        for label, text in (("reasons", "; ".join(r.reasons)), ("masked", r.masked_text())):
            if text:
                parts.append(Padding(Text(f"{label}: {text}"), (0, 0, 0, 4)))
    return Group(*parts)


def clips_view(rows: list[ClipRow], *, title: str, width: int) -> RenderableType:
    """`clips_table` on a terminal at least `TABLE_MIN_COLUMNS` wide, else `clips_blocks`."""
    if width >= TABLE_MIN_COLUMNS:
        return clips_table(rows, title=title)
    return clips_blocks(rows, title=title)
