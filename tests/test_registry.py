"""Registry: decorator, lazy targets, entry-point plug-ins from a real dist-info, unknown names."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from gesturebank.errors import InputError
from gesturebank.registry import Registry

GROUP = "gesturebank_test.widgets"  # a group no installed package uses


def write_plugin(root: Path, *, module: str, source: str, entry_points: str) -> None:
    """An installed-looking distribution: `module`.py plus `<module>-1.0.dist-info` on `root`."""
    (root / f"{module}.py").write_text(source)
    info = root / f"{module}-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {module}\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(f"[{GROUP}]\n{entry_points}\n")


@pytest.fixture
def registry() -> Registry[object]:
    return Registry("widget", GROUP)


def test_register_returns_the_factory_and_create_calls_it(registry: Registry[object]) -> None:
    @registry.register("pair")
    def pair(a: object, *, b: object) -> tuple[object, object]:
        return (a, b)

    assert registry.get("pair") is pair
    assert registry.create("pair", 1, b=2) == (1, 2)
    assert registry.names() == ["pair"]


def test_lazy_target_is_imported_on_first_use_only(
    registry: Registry[object], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "lazy_widget_mod.py").write_text("class Widget:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "lazy_widget_mod", raising=False)
    registry.register_lazy("lazy", "lazy_widget_mod:Widget")
    assert registry.names() == ["lazy"]
    registry.check("lazy")
    assert "lazy_widget_mod" not in sys.modules  # listing and checking import nothing
    widget = registry.get("lazy")
    assert widget is sys.modules["lazy_widget_mod"].Widget
    assert registry.get("lazy") is widget


def test_lazy_target_may_name_a_classmethod(
    registry: Registry[object], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A "module:Class.method" target, as the lifters register their `from_config`."""
    source = "class Widget:\n    @classmethod\n    def make(cls, n):\n        return (cls, n)\n"
    (tmp_path / "lazy_method_mod.py").write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "lazy_method_mod", raising=False)
    registry.register_lazy("made", "lazy_method_mod:Widget.make")
    assert registry.create("made", 3) == (sys.modules["lazy_method_mod"].Widget, 3)


def test_entry_point_plugins_are_listed_and_loaded(
    registry: Registry[object], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    write_plugin(
        tmp_path,
        module="gb_plugin_ok",
        source="class Mine:\n    def __init__(self, size):\n        self.size = size\n",
        entry_points="mine = gb_plugin_ok:Mine",
    )
    write_plugin(
        tmp_path,
        module="gb_plugin_broken",
        source="raise ImportError('needs libfoo')\n",
        entry_points="broken = gb_plugin_broken:Thing",
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    for module in ("gb_plugin_ok", "gb_plugin_broken"):
        monkeypatch.delitem(sys.modules, module, raising=False)
    assert registry.names() == ["broken", "mine"]
    registry.check("broken")  # listed: checking does not import it
    assert registry.create("mine", 3).size == 3  # type: ignore[attr-defined]
    with pytest.raises(InputError, match=r"widget plug-in 'broken' failed to load: needs libfoo"):
        registry.get("broken")


def test_unknown_names_list_what_is_available(registry: Registry[object]) -> None:
    with pytest.raises(InputError, match=r"^unknown widget 'x' \(--widget\); none is registered$"):
        registry.get("x")
    registry.register("b")(object)
    registry.register_lazy("a", "nowhere:at_all")
    for call in (registry.get, registry.check):
        with pytest.raises(InputError, match=r"^unknown widget 'x' \(--widget\); one of: a, b$"):
            call("x")
