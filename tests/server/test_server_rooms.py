"""The server's structure holds: one job registry handed to every kind of job, a handler for every
command of the simulation thread, and `/openapi.json` describing every JSON success body."""

from __future__ import annotations

from typing import get_args

import pytest

from app.server.sim.sim_commands import PauseForReplay, Reset, SimCommand
from app.server.sim.sim_thread import COMMAND_HANDLERS, SimThread, handler_of
from tests.testing.server_harness import client

#: success bodies that are files, not JSON answers (a download in the format asked)
FILES = {("get", "/api/export"), ("get", "/api/recording/export.vcd")}
#: a JSON Schema document: any object by nature
FREE = {("get", "/api/robot/schema")}


def test_every_job_kind_is_given_the_one_registry(server):
    services = server[1].state.services
    runners = (services.axle_fitter, services.ca_calibrator, services.robustness, services.tuner)
    assert all(runner.jobs is services.jobs for runner in runners)


def test_every_command_type_has_its_handler():
    assert set(get_args(SimCommand)) <= set(COMMAND_HANDLERS)
    assert handler_of(PauseForReplay()) is SimThread._on_pause_for_replay
    assert handler_of(Reset()) is SimThread._on_reset
    with pytest.raises(ValueError, match="not a command"):
        handler_of("reset")  # type: ignore[arg-type]


def _resolve(schema: dict, spec: dict) -> dict:
    while "$ref" in schema:
        schema = spec["components"]["schemas"][schema["$ref"].rsplit("/", 1)[-1]]
    return schema


def test_openapi_describes_every_json_success_body(server):
    with client(server[0]) as http:
        spec = http.get("/openapi.json").json()
    bare = []
    for path, operations in spec["paths"].items():
        for method, operation in operations.items():
            for status, answer in operation["responses"].items():
                body = answer.get("content", {}).get("application/json")
                if not status.startswith("2") or body is None or (method, path) in FILES | FREE:
                    continue
                schema = _resolve(body.get("schema", {}), spec)
                described = (
                    schema.get("properties")
                    or schema.get("items")
                    or (schema.get("oneOf") or schema.get("anyOf"))
                )
                if not described:  # `dict[str, Any]`: any object, nothing said
                    bare.append(f"{method.upper()} {path} {status}")
    assert bare == [], f"success bodies without a model: {bare}"
    job = _resolve(
        spec["paths"]["/api/jobs/{job_id}"]["get"]["responses"]["200"]["content"][
            "application/json"
        ]["schema"],
        spec,
    )
    kinds = {_resolve(s, spec)["properties"]["kind"]["const"] for s in job["oneOf"]}
    assert kinds == {"axle-fit", "calibrate-ca", "fit", "robustness", "tune"}
    status = _resolve(job["oneOf"][0], spec)["properties"]["status"]
    assert set(status["enum"]) == {"running", "done", "failed", "cancelled"}
