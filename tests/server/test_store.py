"""The parameter store: versions, diffs, no echo, nothing half-applied, undo/redo, threads."""

import threading

import pytest

from app.params.document import ParameterSet
from app.server.param_store import NothingToUndo, ParameterStore
from gait import Motion


def recording_store():
    store = ParameterStore()
    seen = []
    store.subscribe(lambda snap, changed, source: seen.append((snap.version, changed, source)))
    return store, seen


def test_update_bumps_the_version_and_announces_exactly_what_changed():
    store, seen = recording_store()
    assert store.snapshot().version == 1
    snap = store.update({"motion": {"a_p": 0.07}, "gait": {"swing": {"v": 2.5}}}, "http")
    assert snap.version == 2 and snap.motion.a_p == 0.07 and snap.gait.swing.v == 2.5
    assert seen == [(2, frozenset({"motion.a_p", "swing.v"}), "http")]


def test_an_update_that_changes_nothing_creates_no_version_and_no_event():
    store, seen = recording_store()
    store.update({"motion": {"a_p": 0.0}}, "viser")
    assert store.snapshot().version == 1 and seen == []


def test_a_bad_update_changes_nothing():
    store, seen = recording_store()
    with pytest.raises(ValueError, match="out of range"):
        store.update({"motion": {"a_p": 0.05}, "gait": {"swing": {"v": 99.0}}}, "http")
    with pytest.raises(ValueError, match="unknown field"):
        store.update({"motion": {"a_p": 0.05, "speed": 1}}, "http")
    assert store.snapshot().motion.a_p == 0.0 and store.snapshot().version == 1
    assert seen == []


def test_undo_redo():
    store, seen = recording_store()
    store.update({"motion": {"a_p": 0.05}}, "http")
    store.update({"motion": {"a_p": 0.10}}, "viser")
    assert store.undo("http").motion.a_p == 0.05
    assert store.undo("http").motion.a_p == 0.0
    with pytest.raises(NothingToUndo):
        store.undo("http")
    assert store.redo("http").motion.a_p == 0.05
    assert store.snapshot().version == 6  # every step is a new version, announced
    assert seen[-1] == (6, frozenset({"motion.a_p"}), "http")
    store.update({"motion": {"a_r": 0.1}}, "http")  # a new change clears the redo list
    with pytest.raises(NothingToUndo):
        store.redo("http")


def test_replace_and_unsubscribe():
    store, seen = recording_store()
    unsubscribe = store.subscribe(lambda *a: pytest.fail("unsubscribed callback called"))
    unsubscribe()
    store.replace(ParameterSet(name="fast", motion=Motion(a_p=0.1)), "preset")
    assert store.snapshot().name == "fast"
    assert seen == [(2, frozenset({"name", "motion.a_p"}), "preset")]


def test_concurrent_updates_lose_nothing():
    store = ParameterStore()
    versions = []
    store.subscribe(lambda snap, changed, source: versions.append(snap.version))

    def writer(k):
        for i in range(50):
            store.update({"motion": {"a_p": round(0.001 * (i + 1) * (1 if k else -1), 6)}}, f"t{k}")

    threads = [threading.Thread(target=writer, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(versions) == list(range(2, 2 + len(versions)))
    assert store.snapshot().version == 1 + len(versions)
