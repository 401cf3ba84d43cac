"""One gesture, one undo step (issue 18, item 3): PATCH /api/params with `Artro-Gesture` makes a
version per change, and the changes of one gesture one step of the undo history."""

from __future__ import annotations

import pytest

from app.server.param_store import ParameterStore

GESTURE = "Artro-Gesture"


def test_a_burst_of_changes_with_one_gesture_is_one_undo_step(http):
    start = http.get("/api/params").json()
    versions = []
    for i in range(1, 11):  # ten key presses of 0.005
        r = http.patch(
            "/api/params", json={"motion": {"a_p": 0.005 * i}}, headers={GESTURE: "page-1"}
        )
        assert r.status_code == 200, r.text
        versions.append(r.json()["version"])
    assert versions == list(range(start["version"] + 1, start["version"] + 11))  # each a version
    undone = http.post("/api/params/undo").json()
    assert undone["motion"]["a_p"] == start["motion"]["a_p"]
    assert undone["reverted"] == {"version": versions[-1], "source": "http"}
    redone = http.post("/api/params/redo").json()
    assert redone["motion"]["a_p"] == pytest.approx(0.05)


def test_another_gesture_or_anothers_change_starts_a_new_step(http):
    http.patch("/api/params", json={"motion": {"a_p": 0.01}})
    http.patch("/api/params", json={"motion": {"a_p": 0.02}}, headers={GESTURE: "drag-1"})
    http.patch("/api/params", json={"motion": {"a_p": 0.03}}, headers={GESTURE: "drag-1"})
    http.patch("/api/params", json={"motion": {"a_r": 0.05}})  # someone else, between
    http.patch("/api/params", json={"motion": {"a_p": 0.04}}, headers={GESTURE: "drag-1"})
    http.patch("/api/params", json={"motion": {"a_p": 0.05}}, headers={GESTURE: "drag-2"})
    steps = [http.post("/api/params/undo").json()["motion"] for _ in range(4)]
    assert [(m["a_p"], m["a_r"]) for m in steps] == [
        (0.04, 0.05),  # drag-2 undone
        (0.03, 0.05),  # drag-1 after the other change
        (0.03, 0.0),  # the other change
        (0.01, 0.0),  # drag-1 before it, as one step
    ]


def test_a_gesture_that_ends_where_it_began_leaves_nothing_to_undo():
    store = ParameterStore()
    store.update({"motion": {"a_r": 0.02}}, "http")
    for a_p in (0.01, 0.02, 0.0):  # dragged out and back
        store.update({"motion": {"a_p": a_p}}, "http", gesture="g")
    assert store.undo("http").motion.a_r == 0.0  # the step before the gesture
    store.update({"motion": {"a_p": 0.03}}, "http", gesture="h")
    store.update({"motion": {"a_p": 0.04}}, "http", gesture="h")
    assert store.undo("http").motion.a_p == 0.0


@pytest.mark.parametrize("bad", ["", "x" * 65, "a b", "über".encode()])
def test_a_bad_gesture_name_is_refused_and_changes_nothing(http, bad):
    before = http.get("/api/params").json()
    r = http.patch("/api/params", json={"motion": {"a_p": 0.03}}, headers={GESTURE: bad})
    assert r.status_code == 422, r.text
    assert r.json()["detail"][0]["loc"][:2] == ["header", GESTURE]
    assert http.get("/api/params").json() == before
