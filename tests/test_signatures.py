"""Public functions take at most two positional parameters (issue 42): past the one or two
obvious subjects (`f(clip, *, config, ...)`), a call names what it passes, so a swapped pair of
arguments cannot go unseen. Read with `ast` from the source: every module-level function of the
package whose name has no leading underscore (methods are left to their protocols: torch's
`forward`, the models' `loss`, the NAOqi proxy's calls)."""

from __future__ import annotations

import ast
from pathlib import Path

import gesturebank
from gesturebank.qc.stretches import SIGNALS

ROOT = Path(gesturebank.__file__).parent
MAX_POSITIONAL = 2

# Functions whose positional signature a protocol fixes, with the reason. A new one fails; so does
# an entry here that no longer takes three.
ALLOWED: dict[str, str] = {
    f"gesturebank.qc.stretches.{name}": "a StretchSignal of qc.table: a plug-in's stretch "
    "check is called as signal(clip, config, profile), with parameters named as it likes"
    for name in SIGNALS
}


def too_positional(root: Path, limit: int = MAX_POSITIONAL) -> dict[str, int]:
    """'package.module.function' → its positional parameters, for each public module-level
    function under the package folder `root` with more than `limit`."""
    found = {}
    for path in sorted(root.rglob("*.py")):
        parts = [root.name, *path.relative_to(root).with_suffix("").parts]
        if parts[-1] == "__init__":
            parts.pop()
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in tree.body:
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = len(node.args.posonlyargs) + len(node.args.args)
                if not node.name.startswith("_") and n > limit:
                    found[".".join([*parts, node.name])] = n
    return found


def test_public_functions_take_at_most_two_positional_parameters() -> None:
    found = too_positional(ROOT)
    new = {name: n for name, n in found.items() if name not in ALLOWED}
    assert not new, (
        "public functions with 3+ positional parameters (add `*` after the subject): "
        + ", ".join(f"{name} ({n})" for name, n in sorted(new.items()))
    )
    gone = sorted(set(ALLOWED) - set(found))
    assert not gone, f"no longer positional, remove from ALLOWED: {gone}"


def test_a_function_with_three_positional_parameters_is_found(tmp_path: Path) -> None:
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("def top(a, b, c=1):\n    pass\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "m.py").write_text(
        "def bad(a, /, b, c):\n    def inner(x, y, z):\n        pass\n"
        "def fine(a, b, *, c):\n    pass\n"
        "def rest(a, b, *more):\n    pass\n"
        "def _private(a, b, c):\n    pass\n"
        "async def slow(a, b, c):\n    pass\n"
        "class K:\n    def method(self, a, b, c):\n        pass\n"
    )
    assert too_positional(pkg) == {"pkg.top": 3, "pkg.sub.m.bad": 3, "pkg.sub.m.slow": 3}
