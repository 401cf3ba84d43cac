"""Round trips and optimistic concurrency on a real server: PUT takes what GET and export give;
a stale version (body or If-Match) is refused with the current one and nothing changed."""

import json

import pytest


def test_put_accepts_what_get_returns(http):
    doc = http.get("/api/params").json()
    doc["motion"]["a_p"] = 0.04 if doc["motion"]["a_p"] != 0.04 else 0.05
    response = http.put("/api/params", json=doc)
    assert response.status_code == 200, response.text
    after = response.json()
    assert after["version"] == doc["version"] + 1 and after["motion"] == doc["motion"]
    assert response.headers["etag"] == f'"{after["version"]}"'


def test_put_accepts_an_exported_json_file(http):
    http.patch("/api/params", json={"gait": {"swing": {"v": 2.2}}})
    exported = json.loads(http.get("/api/export", params={"format": "json"}).text)
    http.post("/api/presets/paper/load")
    response = http.put("/api/params", json=exported)
    assert response.status_code == 200, response.text
    assert response.json()["gait"]["swing"]["v"] == 2.2
    assert response.json()["name"] == exported["name"]


def test_get_gives_the_version_as_etag(http):
    response = http.get("/api/params")
    assert response.headers["etag"] == f'"{response.json()["version"]}"'


@pytest.mark.parametrize("how", ["body", "if-match", "weak if-match"])
@pytest.mark.parametrize("method", ["PUT", "PATCH"])
def test_a_stale_version_is_refused_and_changes_nothing(http, how, method):
    mine = http.get("/api/params").json()
    theirs = http.patch("/api/params", json={"motion": {"a_r": 0.03}}).json()  # another client
    body = {"motion": {"a_p": 0.09}}
    if method == "PUT":  # a whole set, as GET gave it
        body = {
            "name": mine["name"],
            "motion": mine["motion"] | body["motion"],
            "gait": mine["gait"],
        }
    headers = {}
    if how == "body":
        body["version"] = mine["version"]
    else:
        prefix = "W/" if how.startswith("weak") else ""
        headers["if-match"] = f'{prefix}"{mine["version"]}"'
    response = http.request(method, "/api/params", json=body, headers=headers)
    assert response.status_code == (409 if how == "body" else 412), response.text
    error = response.json()
    assert error["version"] == theirs["version"]
    assert error["detail"][0]["type"] in ("version_conflict", "precondition_failed")
    assert str(theirs["version"]) in error["message"]
    assert http.get("/api/params").json() == theirs  # the other client's change stays
    http.patch("/api/params", json={"motion": {"a_r": 0.0}})


def test_the_current_version_is_accepted(http):
    mine = http.get("/api/params")
    headers = {"if-match": mine.headers["etag"]}
    body = {"version": mine.json()["version"], "motion": {"a_y": 0.05}}
    response = http.patch("/api/params", json=body, headers=headers)
    assert response.status_code == 200 and response.json()["motion"]["a_y"] == 0.05
    assert http.patch(
        "/api/params", json={"motion": {"a_y": 0}}, headers={"if-match": "*"}
    ).is_success


def test_undo_says_whose_change_it_reverts_and_can_be_limited_to_your_own(http):
    mine = http.patch("/api/params", json={"motion": {"a_p": 0.06}})
    undone = http.post("/api/params/undo").json()
    assert undone["reverted"] == {"version": mine.json()["version"], "source": "http"}
    redone = http.post("/api/params/redo").json()
    assert redone["motion"]["a_p"] == 0.06
    # another client changes something: undo "only if it is still my change" is refused
    http.post("/api/presets/paper/load")
    response = http.post("/api/params/undo", headers={"if-match": f'"{redone["version"]}"'})
    assert response.status_code == 412
    assert http.get("/api/params").json()["name"] == "paper"  # nothing reverted
    undone = http.post("/api/params/undo").json()  # without If-Match: the latest change, anyone's
    assert undone["reverted"]["source"] == "preset"


def test_nothing_to_redo_is_a_409_in_the_error_shape(http):
    http.patch("/api/params", json={"motion": {"a_p": 0.01}})  # clears the redo history
    response = http.post("/api/params/redo")
    assert response.status_code == 409
    assert response.json()["detail"] == [
        {"loc": [], "msg": "nothing to redo", "type": "nothing_to_redo"}
    ]


def test_a_put_of_a_set_for_another_robot_warns_and_keeps_the_robot(http):
    doc = http.get("/api/params").json()
    here = doc["robot"]
    other = "micro" if here != "micro" else "artro"
    answer = http.put("/api/params", json=doc | {"robot": other, "name": "from-elsewhere"})
    assert answer.status_code == 200, answer.text
    (warning,) = answer.json()["warnings"]
    assert f"tuned for the robot {other!r}" in warning and f"here is {here!r}" in warning
    assert http.get("/api/params").json()["robot"] == here
    same = http.put("/api/params", json=http.get("/api/params").json())
    assert same.json()["warnings"] == []
