"""The path view's API against a live server: Clear, re-anchoring on a motion change, and a fitted
axle marked stale once the gait changes (issue 9)."""

from gait import GaitParams
from tests.testing.server_harness import wait_for


def test_clear_forgets_the_path_and_restarts_the_prediction(http):
    wait_for(lambda: len(http.get("/api/path").json()["actual"]) > 10, "a path of 1 s")
    before = http.get("/api/state").json()["sim_time_s"]
    assert http.post("/api/path/clear").json() == {"accepted": "clear"}
    path = wait_for(lambda: (p := http.get("/api/path").json())["anchor"] and p, "a new anchor")
    assert path["actual"][0][0] >= before  # nothing from before the clear
    assert path["anchor"]["t_s"] >= before


def test_the_prediction_reanchors_when_the_motion_or_ca_changes(http):
    for patch in ({"ca": 0.05}, {"a_p": 0.03}, {"ca": 0.0, "a_p": 0.0}):
        wait_for(lambda: http.get("/api/path").json()["anchor"], "an anchor")
        anchor_t = http.get("/api/path").json()["anchor"]["t_s"]
        sim_t = http.get("/api/state").json()["sim_time_s"]
        wait_for(lambda t=sim_t: http.get("/api/state").json()["sim_time_s"] > t + 0.2, "time")
        version = http.patch("/api/params", json={"motion": patch}).json()["version"]
        wait_for(
            lambda v=version: http.get("/api/state").json()["params_version_applied"] >= v,
            "applied",
        )
        new = wait_for(lambda: http.get("/api/path").json()["anchor"], "an anchor")
        assert new["t_s"] > anchor_t, f"{patch}: the prediction stayed at t = {anchor_t}"


def test_a_fitted_axle_is_stale_once_the_gait_changes(server, http):
    services = server[1].state.services
    assert http.get("/api/path").json()["axle_stale"] is False
    # what a successful fit leaves behind (the fit itself is tested in test_server_api.py)
    services.axle_fitter.fitted_gait = services.store.snapshot().gait
    services.sim.paths.set_axle(0.2, "fitted")
    assert http.get("/api/path").json()["axle_stale"] is False
    http.patch("/api/params", json={"motion": {"ca": 0.02}})  # the motion is not the gait
    assert http.get("/api/path").json()["axle_stale"] is False
    v = services.store.snapshot().gait.swing.v
    http.patch("/api/params", json={"gait": {"swing": {"v": v + 0.1}}})
    assert http.get("/api/path").json()["axle_stale"] is True
    http.post("/api/params/undo")
    assert http.get("/api/path").json()["axle_stale"] is False  # the same gait again
    assert http.put("/api/path/axle", json={"axle_m": None}).status_code == 200
    assert http.get("/api/path").json()["axle_stale"] is False


def test_stale_only_applies_to_a_fitted_axle():
    from app.server.jobs.axle_fitter import AxleFitter

    fitter = AxleFitter()
    assert not fitter.stale("fitted", GaitParams())  # nothing fitted yet
    fitter.fitted_gait = GaitParams()
    other = GaitParams.from_dict({"swing": {"v": 2.5}})
    assert fitter.stale("fitted", other) and not fitter.stale("fitted", GaitParams())
    assert not fitter.stale("manual", other) and not fitter.stale("feet", other)
