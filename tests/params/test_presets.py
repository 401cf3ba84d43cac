"""Named presets on disk (app.params.presets): round trip, listing, names, built-ins, atomicity."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

import pytest

from app.params.document import ParameterSet, project_version
from app.params.presets import (
    NAME_RULE,
    PresetError,
    PresetNotFound,
    PresetStore,
    default_data_dir,
    diff,
    write_parameter_set,
)
from gait import GaitParams, Motion


def walk_forward() -> ParameterSet:
    gait = GaitParams.from_dict({"swing": {"v": 2.5}, "clock": {"freq_hz": 1.2}})
    return ParameterSet(name="anything", motion=Motion(a_p=0.07), gait=gait)


@pytest.fixture
def store(tmp_path: Path) -> PresetStore:
    return PresetStore(tmp_path, {"paper": ParameterSet(name="paper")})


def test_save_get_round_trip(store: PresetStore, tmp_path: Path) -> None:
    stored = store.save("walk", walk_forward())
    assert stored.name == "walk"
    assert stored.created.endswith("+00:00")
    assert stored.project_version == project_version()
    loaded = store.get("walk")
    assert loaded == stored
    assert loaded.gait == walk_forward().gait and loaded.motion == walk_forward().motion
    document = json.loads((tmp_path / "presets" / "walk.json").read_text(encoding="utf-8"))
    assert document["name"] == "walk" and document["motion"]["a_p"] == 0.07


def test_save_replaces_existing(store: PresetStore) -> None:
    store.save("walk", walk_forward())
    store.save("walk", ParameterSet())
    assert store.get("walk").motion == Motion()


def test_list_builtins_first_then_sorted(store: PresetStore) -> None:
    for name in ("zeta", "Alpha", "mid-1.v2"):
        store.save(name, walk_forward())
    infos = store.list()
    assert [(i.name, i.builtin) for i in infos] == [
        ("paper", True),
        ("Alpha", False),
        ("mid-1.v2", False),
        ("zeta", False),
    ]
    assert infos[1].motion == dataclasses.asdict(Motion(a_p=0.07))
    assert infos[1].created and store.problems == []
    assert infos[0].to_dict()["builtin"] is True


def test_list_without_directory(tmp_path: Path) -> None:
    store = PresetStore(tmp_path / "missing", {})
    assert store.list() == [] and store.problems == []


@pytest.mark.parametrize("name", ["../x", "a/b", "", ".hidden", "x" * 65, "con..x", "end.", "a\n"])
def test_bad_names_rejected(store: PresetStore, tmp_path: Path, name: str) -> None:
    for call in (lambda: store.save(name, walk_forward()), lambda: store.get(name)):
        with pytest.raises(PresetError, match="allowed: 1 to 64 characters") as info:
            call()
        assert isinstance(info.value, ValueError)
        assert NAME_RULE in str(info.value)
    with pytest.raises(PresetError):
        store.delete(name)
    assert not (tmp_path / "presets").exists() or list((tmp_path / "presets").iterdir()) == []
    assert not (tmp_path / "x.json").exists()


def test_longest_name_accepted(store: PresetStore) -> None:
    name = "a" + "b_.-" * 15 + "xyz"
    assert len(name) == 64
    assert store.save(name, walk_forward()).name == name


def test_builtins_read_only(store: PresetStore, tmp_path: Path) -> None:
    assert store.get("paper") == ParameterSet(name="paper")
    with pytest.raises(PresetError, match="'paper' is built in and read-only"):
        store.save("paper", walk_forward())
    with pytest.raises(PresetError, match="'paper' is built in and read-only"):
        store.delete("paper")
    assert not (tmp_path / "presets" / "paper.json").exists()


def test_delete_and_not_found(store: PresetStore) -> None:
    store.save("walk", walk_forward())
    store.delete("walk")
    with pytest.raises(PresetNotFound, match="no preset named 'walk'"):
        store.get("walk")
    with pytest.raises(PresetNotFound):
        store.delete("walk")
    assert [i.name for i in store.list()] == ["paper"]


def test_crash_during_save_keeps_old_file(
    store: PresetStore, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store.save("walk", walk_forward())
    target = tmp_path / "presets" / "walk.json"
    before = target.read_bytes()
    written: list[str] = []

    def crash(src: str | os.PathLike[str], dst: str | os.PathLike[str]) -> None:
        written.append(Path(src).read_text(encoding="utf-8"))  # the temp file is complete
        raise OSError("simulated power loss")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(OSError, match="simulated power loss"):
        store.save("walk", ParameterSet())
    assert json.loads(written[0])["motion"]["a_p"] == 0.0
    assert target.read_bytes() == before
    assert sorted(p.name for p in target.parent.iterdir()) == ["walk.json"]
    monkeypatch.undo()
    assert store.get("walk").motion == Motion(a_p=0.07)


def test_invalid_files_skipped_and_reported(store: PresetStore, tmp_path: Path) -> None:
    store.save("good", walk_forward())
    presets = tmp_path / "presets"
    (presets / "broken.json").write_text("{not json", encoding="utf-8")
    (presets / "range.json").write_text('{"motion": {"a_p": 9}}', encoding="utf-8")
    (presets / "binary.json").write_bytes(b"\xff\xfe\x00")
    (presets / "paper.json").write_text("{}", encoding="utf-8")
    (presets / ".bad name.json").write_text("{}", encoding="utf-8")
    (presets / "notes.txt").write_text("ignored", encoding="utf-8")
    assert [i.name for i in store.list()] == ["paper", "good"]
    problems = {p.file: p.error for p in store.problems}
    assert set(problems) == {
        "broken.json",
        "range.json",
        "binary.json",
        "paper.json",
        ".bad name.json",
    }
    assert "not valid JSON" in problems["broken.json"]
    assert "out of range" in problems["range.json"]
    assert "built-in" in problems["paper.json"]
    with pytest.raises(PresetError, match="'broken' cannot be read: not valid JSON"):
        store.get("broken")


def test_diff_lists_exactly_the_changed_fields() -> None:
    a = ParameterSet()
    b = ParameterSet(
        name="other",
        created="2020-01-01T00:00:00+00:00",
        motion=Motion(a_p=0.07, ca=-0.01),
        gait=GaitParams.from_dict({"swing": {"v": 2.5}, "load": {"enabled": False}}),
    )
    assert diff(a, b) == [
        {"field": "motion.a_p", "a": 0.0, "b": 0.07},
        {"field": "motion.ca", "a": 0.0, "b": -0.01},
        {"field": "swing.v", "a": 2.0, "b": 2.5},
        {"field": "load.enabled", "a": True, "b": False},
    ]
    assert diff(b, b) == [] and PresetStore.diff(a, a) == []


def test_default_data_dir(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("ARTRO_DATA_DIR", str(tmp_path))
    assert default_data_dir() == tmp_path
    monkeypatch.delenv("ARTRO_DATA_DIR")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert default_data_dir() == tmp_path / "xdg" / "artro-gait-studio"
    monkeypatch.setenv("XDG_DATA_HOME", "relative/ignored")  # the spec: absolute paths only
    monkeypatch.setenv("HOME", str(tmp_path))
    assert default_data_dir() == tmp_path / ".local" / "share" / "artro-gait-studio"
    monkeypatch.delenv("XDG_DATA_HOME")
    assert default_data_dir() == tmp_path / ".local" / "share" / "artro-gait-studio"


def test_a_robot_starts_in_its_own_newest_tune_where_its_default_is_another_robots(
    tmp_path: Path,
) -> None:
    """A robot of one's own named ArtRo's `robust` and so started, and fell, in it even after a
    tune for it was saved (a description may only name a built-in preset)."""
    robust = ParameterSet(name="robust", robot="artro")
    store = PresetStore(tmp_path, {"paper": ParameterSet(name="paper"), "robust": robust})
    assert store.start_for("mine", "robust") is robust  # nothing saved for it yet
    older = dataclasses.replace(walk_forward(), robot="mine", created="2026-11-27T10:00:00+00:00")
    newer = dataclasses.replace(older, created="2026-11-28T10:00:00+00:00")
    store.directory.mkdir(parents=True)
    for name, pset in (("tuned-mine", newer), ("first-try", older),
                       ("tuned-other", dataclasses.replace(newer, robot="other"))):  # fmt: skip
        write_parameter_set(store._path(name), dataclasses.replace(pset, name=name))
    assert store.start_for("mine", "robust").name == "tuned-mine"  # the newest of its own
    assert store.start_for("artro", "robust") is robust  # its default was tuned for it: kept
    assert store.start_for("nobody", "robust") is robust
