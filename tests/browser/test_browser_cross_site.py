"""A page of another site in a real Chromium attacks the studio (no-cors POSTs, WebSockets to the
scope and to the viser port): everything is refused, and the studio page itself still works."""

import http.server
import shutil
import threading

import httpx
import pytest
import viser
from playwright.sync_api import expect, sync_playwright

from tests.testing.server_harness import free_port, running_server

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
ARGS = ["--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking"]

EVIL_PAGE = """<!doctype html><html><body><script>
window.results = {};
function probe(url, protocols) {
  return new Promise((resolve) => {
    const out = { opened: false, messages: 0 };
    const ws = new WebSocket(url, protocols);
    ws.onopen = () => { out.opened = true; };
    ws.onmessage = () => { out.messages += 1; ws.close(); };  // one is enough to know
    ws.onclose = (e) => { out.code = e.code; resolve(out); };
    setTimeout(() => { out.hung = true; resolve(out); }, 10000);  // a bound for a failing test
  });
}
async function attack(studio, viserUrl, viserVersion) {
  const r = window.results;
  const body = JSON.stringify({ motion: { a_p: 0.11 }, gait: {} });
  const paths = ["/api/import", "/api/presets/paper/load", "/api/sim/pause", "/api/sim/reset"];
  for (const path of paths) {
    try {
      await fetch(studio + path, { method: "POST", mode: "no-cors",
                                   headers: { "Content-Type": "text/plain" }, body });
      r[path] = "sent";
    } catch (e) { r[path] = "failed: " + e; }
  }
  r.scope = await probe(studio.replace("http:", "ws:") + "/ws/scope", []);
  r.viser = await probe(viserUrl, ["viser-v" + viserVersion]);
  return r;
}
</script></body></html>"""


class _EvilHandler(http.server.BaseHTTPRequestHandler):
    def do_GET(self) -> None:
        body = EVIL_PAGE.encode()
        self.send_response(200)
        self.send_header("Content-Type", "text/html")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args) -> None:
        pass


@pytest.fixture(scope="module")
def studio(tmp_path_factory):
    with running_server(tmp_path_factory.mktemp("data"), viewer=True) as (base_url, app):
        evil = http.server.ThreadingHTTPServer(("127.0.0.1", free_port()), _EvilHandler)
        thread = threading.Thread(target=evil.serve_forever, daemon=True)
        thread.start()
        try:
            with sync_playwright() as p, httpx.Client(base_url=base_url, timeout=10) as client:
                browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
                yield base_url, app, f"http://127.0.0.1:{evil.server_port}/", browser, client
                browser.close()
        finally:
            evil.shutdown()


def test_a_page_of_another_site_cannot_change_or_watch_anything(studio):
    base_url, app, evil_url, browser, client = studio
    before = client.get("/api/params").json()
    resets = client.get("/api/state").json()["resets"]
    viser_url = f"ws://127.0.0.1:{app.state.services.config.viser_port}"
    page = browser.new_page()
    page.goto(evil_url)
    results = page.evaluate(
        "([s, v, ver]) => attack(s, v, ver)", [base_url, viser_url, viser.__version__]
    )
    page.close()
    assert all(results[p] == "sent" for p in ("/api/import", "/api/sim/pause")), results
    state = client.get("/api/state").json()
    assert client.get("/api/params").json() == before
    assert state["paused"] is False and state["resets"] == resets
    assert results["scope"] == {"opened": False, "messages": 0, "code": 1006}
    # viser's socket is refused on connect, before it sends the scene or takes a message
    assert results["viser"]["messages"] == 0 and results["viser"]["code"] == 1008


def test_the_studio_page_still_works(studio):
    base_url, _app, _evil, browser, client = studio
    page = browser.new_page()
    page.goto(base_url + "/")
    page.wait_for_function("window.artro && window.artro.framesReceived > 5", timeout=30_000)
    # the 3D view's own socket is served: its (docked) control panel arrives over it
    panel = page.frame_locator("#viser-frame").locator('[data-dock-tab="viser-control-panel"]')
    expect(panel).to_be_visible(timeout=30_000)
    status = page.evaluate(
        """async () => (await fetch('/api/sim/pause', {method: 'POST',
             headers: {'Content-Type': 'application/json'}})).status"""
    )
    assert status == 200
    assert any(client.get("/api/state").json()["paused"] for _ in range(1000))  # at its next frame
    assert client.post("/api/sim/resume").status_code == 200
    page.close()


def test_the_fit_button_runs_the_axle_fit_as_a_background_job(studio):
    """The page's "Fit b" starts POST /api/jobs/axle-fit (202) and follows the job to its end;
    the server answers other requests meanwhile."""
    base_url, app, _evil, browser, client = studio
    assert client.patch("/api/params", json={"motion": {"a_p": 0.07}}).status_code == 200
    page = browser.new_page()
    page.goto(base_url + "/")
    with page.expect_response(lambda r: r.url.endswith("/api/jobs/axle-fit")) as started:
        page.locator("#axle-fit").click()
    assert started.value.status == 202
    job_id = started.value.json()["id"]
    assert client.get("/api/health").status_code == 200
    app.state.services.axle_fitter.jobs.get(job_id).finished.wait(300)
    job = client.get(f"/api/jobs/{job_id}").json()
    assert job["status"] == "done", job
    expected = "b_eff" if job["result"]["applied"] else "not applied"
    expect(page.locator("#path-message")).to_contain_text(expected, timeout=10_000)
    page.close()
