"""Loading a preset can keep the motion in use, so that the robot walks on (issue 9)."""


def test_load_keeps_the_motion_when_asked(http):
    http.post("/api/presets/tuned/load")
    walking = {"a_r": 0.0, "a_p": 0.05, "a_y": 0.1, "ca": 0.02}
    http.patch("/api/params", json={"motion": walking})
    kept = http.post("/api/presets/paper/load", params={"keep_motion": "true"}).json()
    assert kept["name"] == "paper" and kept["motion"] == walking
    assert kept["gait"] == http.get("/api/presets/paper").json()["gait"]
    replaced = http.post("/api/presets/tuned/load").json()  # the default: the preset's motion
    assert replaced["motion"] == http.get("/api/presets/tuned").json()["motion"]
    assert http.post("/api/presets/paper/load", params={"keep_motion": "x"}).status_code == 422
    assert http.get("/api/params").json()["version"] == replaced["version"]  # nothing changed
