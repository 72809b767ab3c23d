"""autobal explore in a real browser (Playwright driving Debian's headless chromium): sliders moved by the keyboard,
the numbers shown equal ``autobal run`` on the saved scene, the page loads nothing from outside 127.0.0.1, a bad
setting is shown as such and the server survives it, and the p90 latency from a key press to the updated page over
60 changes is under 50 ms; the statics page (pump_pe600_statics) shows autobal run's numbers too, and so does the
spin-up page (spinup_jeffcott_deadline_5s) after "re-optimise", which shows its progress while the page answers.
Needs the ``explore`` and ``browser`` extras and /usr/bin/chromium; skipped without."""

import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("bokeh")
sync_api = pytest.importorskip("playwright.sync_api")
CHROMIUM = Path("/usr/bin/chromium")
# one worker under pytest-xdist (--dist loadgroup): one server and one browser for the module
pytestmark = [pytest.mark.slow, pytest.mark.cli, pytest.mark.xdist_group("explore_browser"),
              pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium at /usr/bin/chromium")]

SCENE = "pump_pe600_dynamics"
LATENCY_P90_MS = 50.0
CHANGES = 60
WARMUP = 40
ROUNDS = 5
POLL_MS = 5
START_S = 120.0  # the server prints its URL within this (imports, the first solve)

# the page's Bokeh widgets live in shadow roots: find by id through them, watch the update counter
DEEP = """
window.__deep = (sel, root = document) => {
  const hit = root.querySelector(sel);
  if (hit) return hit;
  for (const el of root.querySelectorAll('*')) {
    if (el.shadowRoot) { const x = window.__deep(sel, el.shadowRoot); if (x) return x; }
  }
  return null;
};
window.__down = []; window.__shown = [];
document.addEventListener('keydown', () => window.__down.push(performance.now()), true);
const root = window.__deep('#seq').getRootNode();
new MutationObserver(() => {
  const s = window.__deep('#seq');
  if (s && Number(s.textContent) !== window.__last) { window.__last = Number(s.textContent);
    window.__shown.push(performance.now()); }
}).observe(root, {subtree: true, childList: true, characterData: true});
window.__last = Number(window.__deep('#seq').textContent);
"""


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """``autobal explore SCENE --no-browser`` in its own process (cwd: a temporary folder); its URL."""
    yield from serving(SCENE, tmp_path_factory.mktemp("explore"))


def serving(scene: str, cwd: Path):
    """Start ``autobal explore scene --no-browser`` in ``cwd``; yield (URL, cwd, process); stop it."""
    env = os.environ | {"PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "autobal", "explore", scene, "--no-browser"], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in proc.stdout], daemon=True).start()
    url, deadline = None, time.monotonic() + START_S
    while url is None and time.monotonic() < deadline:
        try:
            line = lines.get(timeout=1.0)
        except queue.Empty:
            continue
        if line.startswith("autobal explore: http://127.0.0.1:"):
            url = line.split()[2]
    if url is None:
        proc.kill()
        pytest.fail(f"autobal explore printed no URL within {START_S:g} s")
    yield url, cwd, proc
    proc.terminate()
    proc.wait(timeout=30)


@pytest.fixture(scope="module")
def browser():
    """One headless Chromium for the module (Playwright's sync API runs one instance per thread)."""
    with sync_api.sync_playwright() as p:
        chromium = p.chromium.launch(executable_path=str(CHROMIUM), args=["--no-sandbox"])
        yield chromium
        chromium.close()


@pytest.fixture(scope="module")
def page(server, browser):
    pg = browsing(browser, server[0])
    yield pg
    pg.close()


def browsing(browser, url: str, ready: str = "#gap", init: str | None = None):
    """A new page of ``browser`` on ``url`` (``init``: a script run first), once it shows ``ready`` (its requests
    outside 127.0.0.1 in ``pg.outside``)."""
    pg = browser.new_page(viewport={"width": 1400, "height": 1000})
    if init:
        pg.add_init_script(init)
    outside = []
    pg.on("request", lambda r: None if r.url.startswith("http://127.0.0.1:") or r.url.startswith("ws://127.0.0.1:")
          else outside.append(r.url))
    pg.goto(url)
    pg.wait_for_selector(ready, timeout=60_000)
    pg.evaluate(DEEP)
    pg.outside = outside
    return pg


def slider(pg, path: str, explorer=None):
    """The keyboard handle of the slider of scene path ``path`` (the page lists them in the explorer's order;
    default the DeviceExplorer of SCENE)."""
    from autobal.explore import DeviceExplorer

    order = [p.path for p in (explorer or DeviceExplorer(SCENE)).params]
    return pg.locator(".noUi-handle").nth(order.index(path))


def change(pg, handle, key: str, timeout_s: float = 10.0) -> float:
    """Press ``key`` on a slider handle, wait for the page's update; the latency key press -> DOM update, ms."""
    n = pg.evaluate("window.__shown.length")
    handle.press(key)
    # polled every POLL_MS, not at every animation frame (Playwright's default): a frame loop would keep the
    # renderer busy while the server computes; the latency is timed in the page, not by this wait
    pg.wait_for_function(f"window.__shown.length > {n}", timeout=timeout_s * 1e3, polling=POLL_MS)
    return pg.evaluate("window.__shown[window.__shown.length - 1] - window.__down[window.__down.length - 1]")


def save_and_run(pg, out: Path | None = None) -> tuple[Path, dict]:
    """Press "save scene" and run ``autobal run`` on the scene the page saved (into ``out``, default beside it): the
    scene's path and its results.json."""
    pg.locator("button", has_text="save scene").click()
    pg.wait_for_selector("#saved_path", timeout=10_000)
    saved = Path(pg.locator("#saved_path").text_content())
    assert saved.is_file()
    out = out or saved.parent / "run"
    done = subprocess.run([sys.executable, "-m", "autobal", "run", str(saved), "--out", str(out), "--quiet"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return saved, json.loads((out / "results.json").read_text())


def shown(pg) -> dict:
    return json.loads(pg.locator("#exact").text_content())


def test_numbers_shown_equal_autobal_run_on_the_saved_scene(server, page, tmp_path):
    for path, key, times in (("device.disc.face.base_gap", "ArrowRight", 3),
                             ("device.dynamics.cavity_volume", "ArrowRight", 5),
                             ("device.dynamics.regulator.spring_stiffness", "ArrowLeft", 4)):
        handle = slider(page, path)
        for _ in range(times):
            change(page, handle, key)
    live = shown(page)
    text = {k: float(page.locator(f"#{k}").text_content()) for k in ("gap", "decay", "amp0", "peak0_hz")}
    saved, res = save_and_run(page, tmp_path / "run")
    head, stab = res["frequency"]["headline"], res["stability"]
    assert live["decay_rate"] == pytest.approx(stab["margin"]["decay_rate"], rel=1e-8)
    assert live["min_damping_ratio"] == pytest.approx(stab["margin"]["min_damping_ratio"], rel=1e-8)
    assert len(live["peaks"]) == len(head["peaks"]) >= 1
    for a, b in zip(live["peaks"], head["peaks"], strict=True):
        assert a["omega"] == pytest.approx(b["omega"], rel=1e-7)
        assert a["amplitude"] == pytest.approx(b["amplitude"], rel=1e-8)
    assert live["amplitude_at_omega0"] == pytest.approx(head["at_operating_speed"]["amplitude"], rel=1e-8)
    assert live["static_amplitude"] == pytest.approx(head["static_amplitude"], rel=1e-8)
    # the gap: the batch path's IPOPT statics of the saved scene (the dynamic analyses' operating point)
    import autobal
    from autobal.analysis.numerics.linearize import Setup
    from autobal.parts.device import dynamic_device

    scene = autobal.load(saved)
    setup = Setup(dynamic_device(scene), scene.analyses.frequency.operating_ratio)
    assert live["gap"] == pytest.approx(setup.static.values["u"] * setup.dev.scales["z_B"], rel=1e-8)
    # and the 6-digit text the page shows is those numbers
    assert text["gap"] == pytest.approx(live["gap"] * 1e6, rel=1e-5)
    assert text["decay"] == pytest.approx(stab["margin"]["decay_rate"], rel=1e-5)
    assert text["amp0"] == pytest.approx(head["at_operating_speed"]["amplitude"] * 1e6, rel=1e-5)  # µm
    assert text["peak0_hz"] == pytest.approx(head["peaks"][0]["omega"] / (2 * np.pi), rel=1e-5)
    assert page.outside == []  # BokehJS from this server, nothing fetched from elsewhere


def test_a_setting_without_a_regulated_point_is_shown_and_the_server_survives(server, page):
    handle = slider(page, "device.regulator.supply_pressure")
    change(page, handle, "Home")  # 8 MPa: below what the regulator needs
    verdict = page.locator("#verdict_text").text_content()
    assert "NO STATICS" in verdict and "valve on its stop" in verdict and "supply_pressure" in verdict
    assert "last good answer" in page.locator("#status_text").text_content()
    assert shown(page) == {}  # no number is shown as current
    change(page, handle, "End")
    change(page, handle, "PageDown")  # back to a regulated point
    assert server[2].poll() is None
    assert "current" in page.locator("#status_text").text_content()
    assert shown(page)["decay_rate"] > 0


# the websocket frames the page sends, counted
SENT = """const Native = window.WebSocket; window.__sent = 0;
window.WebSocket = function (...args) { const w = new Native(...args), send = w.send.bind(w);
  w.send = (d) => { window.__sent += 1; send(d); }; return w; };
window.WebSocket.prototype = Native.prototype;"""


def test_a_change_is_one_message_from_the_browser(server, browser):
    """The page sends the server one Bokeh message per slider change (its value: header, metadata and content, three
    websocket frames) and nothing else: the sliders' value_throttled and the plots' automatic ranges stay in the
    browser (explore._browser_only), which would otherwise add a message each, and the server's reply each."""
    pg = browsing(browser, server[0], init=SENT)
    try:
        handle = slider(pg, "device.dynamics.cavity_volume")
        change(pg, handle, "ArrowRight")
        time.sleep(1.0)  # what the browser would send back after an update (the ranges) is sent by now
        before = pg.evaluate("window.__sent")
        for key in ("ArrowLeft", "ArrowRight") * 3:
            change(pg, handle, key)
        time.sleep(1.0)
        assert pg.evaluate("window.__sent") - before == 6 * 3
    finally:
        pg.close()


def test_latency_p90_from_key_press_to_update(page):
    """The p90 of key press -> updated page over CHANGES changes (after WARMUP unmeasured ones), in up to ROUNDS
    rounds: the best round's p90 is the page's (a round that a background process of the machine interrupts is
    measured again, as timeit takes the best of its repeats); every round is printed."""
    handle = slider(page, "device.dynamics.cavity_volume")
    gap = slider(page, "device.disc.face.base_gap")
    p90s = []
    for _ in range(ROUNDS):
        lat = []
        for i in range(WARMUP + CHANGES):
            key = "ArrowRight" if (i // 10) % 2 == 0 else "ArrowLeft"
            ms = change(page, handle if i % 2 else gap, key)
            if i >= WARMUP:
                lat.append(ms)
        p50, p90 = np.percentile(lat, [50, 90])
        p90s.append(p90)
        print(f"explore latency over {CHANGES} changes: p50 {p50:.1f} ms, p90 {p90:.1f} ms, max {max(lat):.1f} ms")
        if p90 < LATENCY_P90_MS:
            break
    assert min(p90s) < LATENCY_P90_MS


def test_report_button_writes_the_report_of_autobal_run(server, page):
    """"report": the saved scene run by autobal.run in a thread, its report.html written; the page stays live."""
    page.locator("button", has_text="report").click()
    handle = slider(page, "device.dynamics.regulator.stem_mass")
    change(page, handle, "ArrowRight")  # the page answers while the run goes on
    change(page, handle, "ArrowLeft")
    page.wait_for_selector("#report_path", timeout=300_000)
    report = Path(page.locator("#report_path").text_content())
    assert report.name == "report.html" and report.is_file()
    results = json.loads((report.parent / "results.json").read_text())
    assert results["status"] == "ok" and {"frequency", "stability"} <= set(results)


def test_statics_page_numbers_equal_autobal_run_on_the_saved_scene(browser, tmp_path_factory):
    """The statics page (pump_pe600_statics): after slider moves, the operating point, p1_kr and dp_kr it shows
    equal ``autobal run`` of the scene it saves (IPOPT), and its 6-digit text is those numbers."""
    from autobal.explore import StaticsExplorer

    statics = "pump_pe600_statics"
    serve = serving(statics, tmp_path_factory.mktemp("explore_statics"))
    url = next(serve)[0]
    pg = None
    try:
        pg = browsing(browser, url)
        ex = StaticsExplorer(statics)
        for path, key, times in (("device.regulator.supply_pressure", "ArrowRight", 3),
                                 ("device.barrier.supply_throttle.diameter", "ArrowLeft", 2)):
            handle = slider(pg, path, ex)
            for _ in range(times):
                change(pg, handle, key)
        live = shown(pg)
        text = {k: float(pg.locator(f"#{k}").text_content()) for k in ("gap", "leak", "p1_kr", "dp_kr")}
        res = save_and_run(pg)[1]["statics"]
        ex_, crit = res["exact"], res["critical_exact"]
        for key, ref in (("gap", ex_["z0"]), ("leak", ex_["Q_e"]), ("dp", ex_["dp"]), ("p1_kr", crit["p1_kr"]),
                         ("dp_kr", crit["dp_kr"]), ("margin_to_p1_kr", crit["p1_kr"] - ex_["p1"])):
            assert live[key] == pytest.approx(ref, rel=1e-8), key
        assert crit["p1_kr"] != pytest.approx(39487806.18, rel=1e-6)  # moved from the shipped scene's
        for key, factor in (("gap", 1e6), ("leak", 1e3), ("p1_kr", 1e-6), ("dp_kr", 1e-6)):  # µm, L/s, MPa
            assert text[key] == pytest.approx(live[key] * factor, rel=1e-5), key
        assert "regulating" in pg.locator("#verdict_text").text_content()
        assert pg.outside == []
    finally:  # the page closed, the server stopped (the teardown after its yield), also when the page failed
        if pg is not None:
            pg.close()
        next(serve, None)


SPINUP = "spinup_jeffcott_deadline_5s"
OPTIMISE_S = 600.0  # the batch run's optimisation on the loaded machine: a few seconds, here at most this

# the spin-up page: at each update shown, the re-optimise button's label then (the page answering meanwhile)
LABELS = """
window.__labels = [];
new MutationObserver(() => window.__labels.push(window.__deep('.bk-btn-primary').textContent))
  .observe(window.__deep('#seq').getRootNode(), {subtree: true, childList: true, characterData: true});
"""


def optimum_profile(pg) -> list:
    """The current optimum's deflection delta/e as the page's plot holds it."""
    return pg.evaluate("Array.from(Bokeh.documents[0].get_model_by_name('optimum_profile').get_column('d'))")


def test_spinup_page_numbers_equal_autobal_run_and_reoptimise_keeps_the_page_live(browser, tmp_path_factory):
    """The spin-up page (spinup_jeffcott_deadline_5s): rotor sliders moved, "re-optimise" shows its progress, a
    slider change is answered while it runs, the new profile is plotted when it is done; then the peaks (delta/e and
    µm), the critical speed (rpm), AF and SM shown equal ``autobal run`` of the scene the page saves."""
    from autobal.explore import SpinupExplorer

    serve = serving(SPINUP, tmp_path_factory.mktemp("explore_spinup"))
    url = next(serve)[0]
    pg = None
    try:
        pg = browsing(browser, url, "#critical")
        pg.evaluate(LABELS)
        ex = SpinupExplorer(SPINUP)

        def exact() -> dict:
            return json.loads(pg.locator("#exact").text_content())

        def optimised_now():  # the optimum shown was optimised for the page's current settings
            pg.wait_for_function("window.__deep('#exact') && JSON.parse(window.__deep('#exact').textContent)"
                                 ".optimum_current", timeout=OPTIMISE_S * 1e3)

        optimised_now()  # the page finds the scene's optimum when it opens
        shipped = exact()
        for path, key, times in (("rotor.damping", "ArrowRight", 3), ("rotor.stiffness", "ArrowLeft", 4),
                                 ("analyses.spinup.max_acceleration", "ArrowRight", 2)):  # the rotor and the drive
            handle = slider(pg, path, ex)
            for _ in range(times):
                change(pg, handle, key, timeout_s=60.0)
        stale = exact()
        assert not stale["optimum_current"] and stale["critical_speed"] < shipped["critical_speed"]
        assert "optimised for other settings" in pg.locator("#verdict_text").text_content()
        stale_profile = optimum_profile(pg)

        # re-optimise: its progress shown, a slider change answered while it runs, the new profile when done
        pg.locator("button", has_text="re-optimise").click()
        pg.wait_for_selector("#optimising", timeout=10_000)
        assert pg.locator(".bk-btn-primary").text_content().startswith("optimising")
        n = pg.evaluate("window.__labels.length")
        change(pg, slider(pg, "rotor.eccentricity", ex), "ArrowRight", timeout_s=60.0)
        answered = pg.evaluate(f"window.__labels.slice({n})")
        assert answered and answered[0].startswith("optimising"), answered  # the change shown during the run
        pg.wait_for_selector("#optimised", timeout=OPTIMISE_S * 1e3)
        # the new profile re-simulated and shown: optimised for the settings at the click (the eccentricity moved
        # since; delta/e does not depend on it), its peak not the stale profile's
        pg.wait_for_function(f"Math.abs(JSON.parse(window.__deep('#exact').textContent).optimum - {stale['optimum']})"
                             f" > {1e-6 * stale['optimum']}", timeout=60_000)
        fresh = exact()
        profile = optimum_profile(pg)
        assert profile != stale_profile and max(map(abs, profile)) == pytest.approx(fresh["optimum"], rel=1e-4)

        pg.locator("button", has_text="re-optimise").click()  # for the current settings
        optimised_now()
        live = exact()
        # the live numbers are the linear response's; CVODES (autobal run's re-simulation) checks them once the page
        # rests, and agrees
        pg.wait_for_function("window.__deep('#crosscheck')", timeout=60_000)
        assert "CVODES's re-simulation (autobal run's) agrees" in pg.locator("#crosscheck").text_content()
        text = {k: float(pg.locator(f"#{k}").text_content()) for k in ("peak_0", "peak_um_0", "critical", "af", "sm")}
        saved, results = save_and_run(pg)
        run = results["spinup"]
        # the live re-simulations (the exact linear response) on the same profile equal the batch run's CVODES to 1e-9
        assert live["optimum"] == pytest.approx(run["peak_deflection_over_e"], rel=1e-9)
        assert live["optimum"] * live["eccentricity"] == pytest.approx(run["peak_deflection_m"], rel=1e-9)
        for key, peak in live["ramps"].items():
            assert peak == pytest.approx(run["baselines"][key]["peak_deflection_over_e"], rel=1e-9), key
        assert live["critical_speed"] == pytest.approx(run["omega_cr_rad_s"], rel=1e-12)
        for key in ("amplification_factor", "separation_margin_pct", "required_separation_margin_pct"):
            assert live["api"][key] == pytest.approx(run["rotor"][key], rel=1e-12), key
        assert run["omega_cr_rad_s"] != pytest.approx(105.0, rel=1e-3)  # moved from the shipped rotor's
        import yaml

        alpha = float(yaml.safe_load(saved.read_text())["analyses"]["spinup"]["max_acceleration"].split()[0])
        ramp = run["baselines"]["max_acceleration_ramp"]["label"]
        assert alpha > 40.0 and ramp.startswith(f"ramp {alpha:.4g} rad/s²"), ramp
        # the text shown: 6 digits (AF and SM 4) of those numbers, in δ/e, µm and rpm
        assert text["peak_0"] == pytest.approx(run["peak_deflection_over_e"], rel=1e-5)
        assert text["peak_um_0"] == pytest.approx(run["peak_deflection_m"] * 1e6, rel=1e-5)
        assert text["critical"] == pytest.approx(run["omega_cr_rad_s"] * 30 / np.pi, rel=1e-5)
        assert text["af"] == pytest.approx(run["rotor"]["amplification_factor"], rel=1e-3)
        assert text["sm"] == pytest.approx(run["rotor"]["separation_margin_pct"], rel=1e-3)
        assert pg.outside == []
    finally:
        if pg is not None:
            pg.close()
        next(serve, None)
