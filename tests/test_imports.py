"""No import cycles inside gesturebank, no stage module that reaches for the CLI, and no import
up a floor (the floors: docs/architecture.md "Floors").

Imports are read with `ast` from the source (module level and inside functions; those under
`if TYPE_CHECKING:` never run and are left out). `from a import b` where `a/b.py` exists counts
as importing `a.b`; relative imports are resolved against the importing module's package.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import gesturebank

ROOT = Path(gesturebank.__file__).parent


def module_files(root: Path) -> dict[str, Path]:
    """Dotted module name → file, for every .py under the package folder `root`."""
    found = {}
    for path in sorted(root.rglob("*.py")):
        parts = [root.name, *path.relative_to(root).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        found[".".join(parts)] = path
    return found


def _type_checking_only(tree: ast.Module) -> set[ast.AST]:
    """Import nodes inside `if TYPE_CHECKING:` blocks."""
    skip: set[ast.AST] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for child in node.body:
                skip.update(ast.walk(child))
    return skip


def imports_of(
    name: str,
    path: Path,
    modules: dict[str, Path],
    *,
    type_checking: bool = False,
    strings: bool = False,
) -> set[str]:
    """The modules of `modules` that module `name` (at `path`) imports when it runs; with
    `type_checking` also those under `if TYPE_CHECKING:`, with `strings` also every string
    constant that names one (`"pkg.mod"`, `"pkg.mod:attr"`: importlib, plug-in tables)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    skip = set() if type_checking else _type_checking_only(tree)
    targets: set[str] = set()
    for node in ast.walk(tree):
        if node in skip:
            continue
        if strings and isinstance(node, ast.Constant) and isinstance(node.value, str):
            if re.fullmatch(r"[A-Za-z_][\w.]*(:\w+)?", node.value):
                targets.add(node.value.partition(":")[0])
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join([*anchor, *([base] if base else [])])
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                targets.add(sub if sub in modules else base)
    return {t for t in targets if t in modules and t != name}


def import_graph(
    root: Path, *, type_checking: bool = False, strings: bool = False
) -> dict[str, set[str]]:
    modules = module_files(root)
    return {
        name: imports_of(name, path, modules, type_checking=type_checking, strings=strings)
        for name, path in modules.items()
    }


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def _describe(component: list[str], graph: dict[str, set[str]]) -> str:
    members = set(component)
    edges = [f"{a} -> {b}" for a in component for b in sorted(graph[a] & members)]
    return "; ".join(edges)


def test_no_import_cycles() -> None:
    graph = import_graph(ROOT)
    found = cycles(graph)
    assert not found, "import cycles:\n" + "\n".join(_describe(c, graph) for c in found)


def _in_cli(module: str) -> bool:
    return module == "gesturebank.cli" or module.startswith("gesturebank.cli.")


def test_no_module_imports_the_cli() -> None:
    graph = import_graph(ROOT)
    users = sorted(
        name
        for name, targets in graph.items()
        if not _in_cli(name) and any(_in_cli(t) for t in targets)
    )
    assert not users, f"stage modules importing gesturebank.cli: {users}"


def test_a_cycle_is_found(tmp_path: Path) -> None:
    """The reader on a real package with a loop through a function-level, a relative and a
    `from pkg import submodule` import; the TYPE_CHECKING import is no edge."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def f():\n    from pkg.sub import b\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "b.py").write_text("from . import c\n")
    (pkg / "sub" / "c.py").write_text(
        "from typing import TYPE_CHECKING\nfrom .. import a\nif TYPE_CHECKING:\n    import pkg.d\n"
    )
    (pkg / "d.py").write_text("import pkg.sub.c\n")
    graph = import_graph(pkg)
    assert graph["pkg.a"] == {"pkg.sub.b"}
    assert graph["pkg.sub.b"] == {"pkg.sub.c"}
    assert graph["pkg.sub.c"] == {"pkg.a"}
    assert cycles(graph) == [["pkg.a", "pkg.sub.b", "pkg.sub.c"]]


# --------------------------------------------------------------------------------------------------
# Floors: a module imports only from its own floor or below. The floors are written once, in the
# table of docs/architecture.md "Floors"; this test reads them from there.

ARCHITECTURE = ROOT.parent / "docs" / "architecture.md"

# Imports that run up a floor today, (importer, imported) module by module, each with the issue
# that removes it. A new upward import fails; so does an entry here that no longer occurs.
KNOWN_UPWARD: dict[tuple[str, str], int] = {}


def floors_from_doc(text: str, package: str = "gesturebank") -> dict[str, int]:
    """Module prefix → floor, from the table under the heading "## Floors" of `text`: rows
    `| N | `name` `name` … | … |`, where `name` stands for `package.name` and `__init__` for the
    package itself."""
    section = text.partition("\n## Floors\n")[2].partition("\n## ")[0]
    floors: dict[str, int] = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 2 or not cells[0].isdigit():
            continue
        for name in re.findall(r"`([\w.]+)`", cells[1]):
            prefix = package if name == "__init__" else f"{package}.{name}"
            assert prefix not in floors, f"{prefix} is on two floors"
            floors[prefix] = int(cells[0])
    return floors


def floor_of(module: str, floors: dict[str, int]) -> int | None:
    """The floor of the longest prefix of `module` in `floors` (the package itself matches only
    itself), None when it has none."""
    best: tuple[int, int] | None = None
    for prefix, floor in floors.items():
        inside = module.startswith(prefix + ".") and "." in prefix
        if (module == prefix or inside) and (best is None or len(prefix) > best[0]):
            best = (len(prefix), floor)
    return None if best is None else best[1]


def upward_imports(
    graph: dict[str, set[str]], floors: dict[str, int]
) -> tuple[list[str], dict[tuple[str, str], str]]:
    """(modules without a floor, {(importer, imported): 'floor a -> floor b'} for every import
    that runs up a floor)."""
    homeless = sorted(m for m in graph if floor_of(m, floors) is None)
    upward = {}
    for importer, targets in graph.items():
        low = floor_of(importer, floors)
        for imported in targets:
            high = floor_of(imported, floors)
            if low is not None and high is not None and high > low:
                upward[(importer, imported)] = f"floor {low} -> floor {high}"
    return homeless, upward


def test_the_floor_table_is_read() -> None:
    floors = floors_from_doc(ARCHITECTURE.read_text(encoding="utf-8"))
    assert floors["gesturebank"] == 0 and floors["gesturebank.errors"] == 0
    assert floors["gesturebank.poses"] < floors["gesturebank.extract"] < floors["gesturebank.lift"]
    assert floors["gesturebank.robot"] < floors["gesturebank.qc"] < floors["gesturebank.datasets"]
    assert floors["gesturebank.datasets"] < floors["gesturebank.report"] < floors["gesturebank.cli"]


def test_no_module_imports_a_higher_floor() -> None:
    floors = floors_from_doc(ARCHITECTURE.read_text(encoding="utf-8"))
    homeless, upward = upward_imports(import_graph(ROOT, strings=True), floors)
    assert not homeless, f"modules on no floor (add them to {ARCHITECTURE.name}): {homeless}"
    new = {edge: how for edge, how in upward.items() if edge not in KNOWN_UPWARD}
    assert not new, "imports up a floor:\n" + "\n".join(
        f"{a} -> {b} ({how})" for (a, b), how in sorted(new.items())
    )


def test_every_known_upward_import_still_occurs() -> None:
    """An exception that was fixed leaves KNOWN_UPWARD, so that it cannot come back unseen."""
    floors = floors_from_doc(ARCHITECTURE.read_text(encoding="utf-8"))
    _, upward = upward_imports(import_graph(ROOT, strings=True), floors)
    gone = sorted(set(KNOWN_UPWARD) - set(upward))
    assert not gone, f"fixed, remove from KNOWN_UPWARD: {gone}"


def test_an_upward_import_is_found(tmp_path: Path) -> None:
    """The floor check on a small package: a function-level import up a floor is found, an
    import down or sideways is not, a submodule gets its own floor, and a module that no table
    row covers is reported."""
    pkg = tmp_path / "pkg"
    for folder in ("base", "stage", "top"):
        (pkg / folder).mkdir(parents=True)
        (pkg / folder / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "base" / "a.py").write_text("def f():\n    from pkg.stage import b\n")
    (pkg / "stage" / "b.py").write_text("from pkg.base import a\nfrom pkg.stage import c\n")
    (pkg / "stage" / "c.py").write_text("import pkg.top.d\n")
    (pkg / "top" / "d.py").write_text("from pkg.stage import b\n")
    (pkg / "loose.py").write_text("")
    table = (
        "# x\n\n## Floors\n\n| floor | modules | what |\n|---|---|---|\n"
        "| 0 | `__init__` `base` | ground |\n| 1 | `stage` | |\n| 2 | `top` `stage.c` | |\n"
        "\n## Next\n\n| 9 | `loose` | not the floor table |\n"
    )
    floors = floors_from_doc(table, package="pkg")
    assert floors == {"pkg": 0, "pkg.base": 0, "pkg.stage": 1, "pkg.top": 2, "pkg.stage.c": 2}
    homeless, upward = upward_imports(import_graph(pkg), floors)
    assert homeless == ["pkg.loose"]
    assert upward == {
        ("pkg.base.a", "pkg.stage.b"): "floor 0 -> floor 1",
        ("pkg.stage.b", "pkg.stage.c"): "floor 1 -> floor 2",  # c has a floor of its own
    }


def test_the_cli_starts_without_torch_or_the_dataset_reader() -> None:
    """Every command's module is imported when the CLI starts (`gesturebank --help`, and each
    `build-dataset` worker, which imports its entry point's module): the work of a command
    imports its stages when it runs. Importing torch here once made every worker of a build
    seconds late to start, and a killed build's workers outlived it."""
    import subprocess
    import sys

    heavy = ("torch", "pyarrow", "open3d", "gesturebank.datasets.store", "gesturebank.synth")
    code = f"import sys, gesturebank.cli; print([m for m in {heavy!r} if m in sys.modules])"
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout.strip() == "[]", run.stdout


def test_an_import_string_up_a_floor_is_found(tmp_path: Path) -> None:
    """An import by name (importlib, a plug-in table) counts for the floors: "pkg.top.d" read
    as a string constant is an edge; a docstring that mentions it is not."""
    pkg = tmp_path / "pkg"
    for folder in ("base", "top"):
        (pkg / folder).mkdir(parents=True)
        (pkg / folder / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "base" / "a.py").write_text(
        '"""Not pkg.top.d here."""\nimport importlib\n\n'
        'def f():\n    return importlib.import_module("pkg.top.d")\n'
    )
    (pkg / "base" / "b.py").write_text('TABLE = {"x": "pkg.top.d:Thing"}\n')
    (pkg / "top" / "d.py").write_text("")
    floors = {"pkg": 0, "pkg.base": 0, "pkg.top": 1}
    assert upward_imports(import_graph(pkg), floors)[1] == {}
    _, upward = upward_imports(import_graph(pkg, strings=True), floors)
    assert set(upward) == {("pkg.base.a", "pkg.top.d"), ("pkg.base.b", "pkg.top.d")}


# --------------------------------------------------------------------------------------------------
# Cycles counted with the imports under `if TYPE_CHECKING:` (a type-only loop is still two
# modules that cannot be understood one without the other). Known ones, each with its issue.

KNOWN_TYPE_CYCLES: dict[tuple[str, ...], int] = {}


def test_no_import_cycles_with_type_checking_imports() -> None:
    found = {tuple(c) for c in cycles(import_graph(ROOT, type_checking=True))}
    new = sorted(found - set(KNOWN_TYPE_CYCLES))
    assert not new, f"import cycles through TYPE_CHECKING imports: {new}"
    gone = sorted(set(KNOWN_TYPE_CYCLES) - found)
    assert not gone, f"fixed, remove from KNOWN_TYPE_CYCLES: {gone}"


def test_a_type_checking_cycle_is_found(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from pkg import b\n")
    (pkg / "b.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.a import X\n"
    )
    assert cycles(import_graph(pkg)) == []
    assert cycles(import_graph(pkg, type_checking=True)) == [["pkg.a", "pkg.b"]]


# --------------------------------------------------------------------------------------------------
# Sizes: a module holds one job, at most MAX_LINES lines, unless its first lines say it is one
# piece (ONE_PIECE, with the reason).

MAX_LINES = 600
ONE_PIECE = "# one piece:"


def oversized(root: Path, limit: int = MAX_LINES) -> dict[str, int]:
    """Module path (relative to `root`) → line count, for every .py over `limit` lines that
    does not carry the ONE_PIECE mark in its first 30 lines."""
    found = {}
    for path in sorted(root.rglob("*.py")):
        lines = path.read_text(encoding="utf-8").splitlines()
        if len(lines) > limit and not any(ONE_PIECE in line for line in lines[:30]):
            found[str(path.relative_to(root))] = len(lines)
    return found


def test_no_module_is_over_600_lines() -> None:
    assert not (big := oversized(ROOT)), f"modules over {MAX_LINES} lines (split them): {big}"


def test_an_oversized_module_is_found(tmp_path: Path) -> None:
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "big.py").write_text("x = 1\n" * 601)
    (tmp_path / "marked.py").write_text(f"{ONE_PIECE} a table\n" + "x = 1\n" * 700)
    (tmp_path / "small.py").write_text("x = 1\n" * 600)
    assert oversized(tmp_path) == {"sub/big.py": 601}


# --------------------------------------------------------------------------------------------------
# The terminal: only the application floor (`app`) and the command line (`cli`) import `rich`.
# Stage modules that still do, each with the issue that moves their printing up.

TERMINAL_FLOORS = ("gesturebank.app", "gesturebank.cli")
KNOWN_RICH: dict[str, int] = {}


def rich_users(root: Path) -> set[str]:
    """Modules under the package folder `root` that import `rich` (anywhere, TYPE_CHECKING
    included)."""
    users = set()
    for name, path in module_files(root).items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            if any(n == "rich" or n.startswith("rich.") for n in names):
                users.add(name)
    return users


def _in_terminal_floor(module: str, floors: tuple[str, ...] = TERMINAL_FLOORS) -> bool:
    return any(module == f or module.startswith(f + ".") for f in floors)


def test_only_app_and_cli_import_rich() -> None:
    stages = {m for m in rich_users(ROOT) if not _in_terminal_floor(m)}
    new = sorted(stages - set(KNOWN_RICH))
    assert not new, f"stage modules importing rich (print from app/ or cli/): {new}"
    gone = sorted(set(KNOWN_RICH) - stages)
    assert not gone, f"fixed, remove from KNOWN_RICH: {gone}"


def test_a_rich_import_outside_the_terminal_floors_is_found(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    (pkg / "cli").mkdir(parents=True)
    (pkg / "stage").mkdir()
    for init in (pkg, pkg / "cli", pkg / "stage"):
        (init / "__init__.py").write_text("")
    (pkg / "cli" / "show.py").write_text("from rich.console import Console\n")
    (pkg / "stage" / "work.py").write_text("def f():\n    import rich\n")
    (pkg / "stage" / "quiet.py").write_text("import richer\n")
    users = rich_users(pkg)
    assert users == {"pkg.cli.show", "pkg.stage.work"}
    assert [u for u in sorted(users) if not _in_terminal_floor(u, ("pkg.cli",))] == [
        "pkg.stage.work"
    ]


# --------------------------------------------------------------------------------------------------
# The whole Config: only the application floor (`app`), the command line (`cli`) and the config
# package itself hold it; a stage takes its own sections. Modules that still import it, each with
# the reason (a new one fails; so does an entry here that no longer imports it).

WHOLE_CONFIG_FLOORS = ("gesturebank.app", "gesturebank.cli", "gesturebank.config")
_LIFTER = "a lifter's from_config(config) (the plug-in protocol: a lifter reads its section)"
_FIXTURE = "test fixtures that build a whole dataset (testing/)"
KNOWN_WHOLE_CONFIG: dict[str, str] = {
    "gesturebank.datasets.records": "DatasetInfo.config: dataset.json stores the config (format)",
    "gesturebank.datasets.refresh": "writes dataset.json (DatasetInfo) and reads its config back",
    "gesturebank.datasets.digest": "content_digest: the digest of the content sections",
    "gesturebank.lift.blazepose_world": _LIFTER,
    "gesturebank.lift.fitted": _LIFTER,
    "gesturebank.lift.geometric": _LIFTER,
    "gesturebank.lift.learned": _LIFTER,
    "gesturebank.lift.multiview.lifter": _LIFTER,
    "gesturebank.lift.resolved": _LIFTER,
    "gesturebank.testing.clips": _FIXTURE,
    "gesturebank.testing.dyads": _FIXTURE,
    "gesturebank.testing.speech_motion": _FIXTURE,
}


def whole_config_users(root: Path, package: str = "gesturebank") -> set[str]:
    """Modules under the package folder `root` that import the top-level `Config` from
    `package.config` (anywhere, TYPE_CHECKING included; relative imports resolved)."""
    users = set()
    for name, path in module_files(root).items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        base_package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom):
                continue
            module = node.module or ""
            if node.level:
                parts = base_package.split(".")
                anchor = parts[: len(parts) - (node.level - 1)]
                module = ".".join([*anchor, *([module] if module else [])])
            if module == f"{package}.config" and any(a.name == "Config" for a in node.names):
                users.add(name)
    return users


def test_only_app_and_cli_take_the_whole_config() -> None:
    stages = {m for m in whole_config_users(ROOT) if not _in_terminal_floor(m, WHOLE_CONFIG_FLOORS)}
    new = sorted(stages - set(KNOWN_WHOLE_CONFIG))
    assert not new, f"stage modules importing the whole Config (take its sections): {new}"
    gone = sorted(set(KNOWN_WHOLE_CONFIG) - stages)
    assert not gone, f"fixed, remove from KNOWN_WHOLE_CONFIG: {gone}"


def test_a_whole_config_import_outside_app_is_found(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    for folder in ("app", "config", "stage"):
        (pkg / folder).mkdir(parents=True)
        (pkg / folder / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "config" / "__init__.py").write_text("class Config: ...\nclass QCConfig: ...\n")
    (pkg / "app" / "run.py").write_text("from pkg.config import Config\n")
    (pkg / "stage" / "typed.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from ..config import Config\n"
    )
    (pkg / "stage" / "own.py").write_text("from pkg.config import QCConfig\n")
    users = whole_config_users(pkg, package="pkg")
    assert users == {"pkg.app.run", "pkg.stage.typed"}
    assert [u for u in sorted(users) if not _in_terminal_floor(u, ("pkg.app",))] == [
        "pkg.stage.typed"
    ]
