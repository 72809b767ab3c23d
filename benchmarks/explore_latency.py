"""Benchmark: where the time of one slider change of ``autobal explore`` goes, from the key press in the browser to
the updated page (pump_pe600_dynamics, headless Chromium driven by Playwright, as tests/test_explore_browser.py).

The server runs in its own process with timing hooks (this module's ``--serve``: Bokeh's websocket handler, the
explorer's ``evaluate`` and the document's ``unhold`` logged with ``time.perf_counter``); the page gets a websocket
wrapper and observers (``performance.now``).  Each change (alternately the face base gap and the cavity volume, one
arrow key each, 50 ms apart) is split into:

- key press -> the change sent on the websocket (the slider's keyboard handling in the browser);
- server: the change received -> its computation started (Bokeh applies the patch, the next tick), the computation
  (:meth:`DeviceExplorer.evaluate`), showing it (the page's properties set, the patch serialised: ``show`` and
  ``doc.unhold``), the patch written to the socket;
- transport: the browser's send -> the patch's last frame received, less the server's part (websocket both ways);
- patch applied in the browser -> the page's update counter in the DOM (the end point of the browser test's
  latency);
- DOM -> painted (the plots' canvases, the next animation frame): after the end point.

Also the messages and bytes per change and the CPU time per change of the server and the browser's processes
(/proc: the load of a shared machine stretches wall times, the CPU time is the work).  Times in s (p50, p90 in
the row).  Needs the ``explore`` and ``browser`` extras and /usr/bin/chromium.
Run: ``python -m benchmarks explore_latency``; writes benchmarks/results/explore_latency.json and .md.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from benchmarks._results import case, write

SCENE = "pump_pe600_dynamics"
SLIDERS = ("device.disc.face.base_gap", "device.dynamics.cavity_volume")
WARMUP, CHANGES = 30, 60
CHROMIUM = "/usr/bin/chromium"

# after the browser test's page script (window.__deep, the key presses and the updates' times): the paints' times
PAINT = """
window.__paint = [];
new MutationObserver(() => requestAnimationFrame(() => setTimeout(() => window.__paint.push(performance.now()), 0)))
  .observe(window.__deep('#seq').getRootNode(), {subtree: true, childList: true, characterData: true});
"""
SOCKET = """
window.__ws = [];
const Native = window.WebSocket;
window.WebSocket = function (...args) {
  const w = new Native(...args), send = w.send.bind(w);
  const size = (d) => typeof d === 'string' ? d.length : (d.byteLength || d.size || 0);
  w.send = (d) => { window.__ws.push(['send', performance.now(), size(d)]); send(d); };
  w.addEventListener('message', (e) => window.__ws.push(['recv', performance.now(), size(e.data)]));
  return w;
};
window.WebSocket.prototype = Native.prototype;
"""


def serve(scene: str, log_path: str) -> None:
    """``autobal explore scene`` with timing hooks, each event a JSON line [perf_counter, what, ...] in
    ``log_path``."""
    from bokeh.document import Document
    from bokeh.server.views import ws

    import autobal.explore as ex

    log = open(log_path, "w", buffering=1)  # noqa: SIM115 (open while the server runs)

    def note(*what):
        log.write(json.dumps([time.perf_counter(), *what]) + "\n")

    on_message, send_message = ws.WSHandler.on_message, ws.WSHandler.send_message
    evaluate, unhold = ex.DeviceExplorer.evaluate, Document.unhold

    async def received(self, fragment):
        if isinstance(fragment, str) and '"attr":"value"' in fragment:
            note("value", self.ws_connection.stream.socket.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY))
        return await on_message(self, fragment)

    async def sent(self, message):
        out = await send_message(self, message)
        note("sent", message.msgtype, sum(len(b) for b in (message.header_json, message.metadata_json,
                                                          message.content_json)))
        return out

    def evaluated(self, values):
        t0 = time.perf_counter()
        out = evaluate(self, values)
        note("computed", t0)
        return out

    def unheld(self):
        unhold(self)
        note("unheld")

    ws.WSHandler.on_message, ws.WSHandler.send_message = received, sent
    ex.DeviceExplorer.evaluate, Document.unhold = evaluated, unheld
    ex.serve(scene, browser=False)


def cpu_by_process(root: int) -> dict:
    """CPU s (user + system) of ``root`` and its descendants by kind (Chromium's --type, else the program)."""
    children, cpu, kinds = {}, {}, {}
    tick = os.sysconf("SC_CLK_TCK")
    for d in filter(str.isdigit, os.listdir("/proc")):
        try:
            stat = Path(f"/proc/{d}/stat").read_text().rsplit(")", 1)[1].split()
            cmd = Path(f"/proc/{d}/cmdline").read_text()
        except OSError:
            continue
        children.setdefault(int(stat[1]), []).append(int(d))
        cpu[int(d)] = (int(stat[11]) + int(stat[12])) / tick
        kinds[int(d)] = next((k for k in ("renderer", "gpu-process", "utility", "zygote") if f"--type={k}" in cmd),
                             "autobal server" if "explore_latency" in cmd else "Playwright driver" if "node" in cmd
                             else "chromium" if "chrom" in cmd else "benchmark")
    out, todo = {}, [root]
    while todo:
        p = todo.pop()
        out[kinds.get(p, "?")] = out.get(kinds.get(p, "?"), 0.0) + cpu.get(p, 0.0)
        todo += children.get(p, [])
    return out


def drive(url: str, log: Path) -> tuple[list[dict], dict, float]:
    """The changes' browser timestamps, the CPU per process over them, and the perf_counter at their start."""
    from playwright.sync_api import sync_playwright

    from autobal.explore import DeviceExplorer
    from tests.test_explore_browser import DEEP

    order = [p.path for p in DeviceExplorer(SCENE).params]
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        page.add_init_script(SOCKET)
        page.goto(url)
        page.wait_for_selector("#gap", timeout=60_000)
        page.evaluate(DEEP)
        page.evaluate(PAINT)
        handles = [page.locator(".noUi-handle").nth(order.index(s)) for s in SLIDERS]

        def change(i: int) -> None:
            n = page.evaluate("window.__shown.length")
            handles[i % 2].press("ArrowRight" if (i // 10) % 2 == 0 else "ArrowLeft")
            page.wait_for_function(f"window.__shown.length > {n}", timeout=30_000, polling=5)
            time.sleep(0.05)

        for i in range(WARMUP):
            change(i)
        page.evaluate("window.__ws = []; window.__down = []; window.__shown = []; window.__paint = []")
        start, cpu0 = time.perf_counter(), cpu_by_process(os.getpid())
        for i in range(CHANGES):
            change(i)
        time.sleep(0.3)
        cpu = {k: (v - cpu0.get(k, 0.0)) / CHANGES for k, v in cpu_by_process(os.getpid()).items()}
        down, shown, paint, frames = (page.evaluate(f"window.__{k}") for k in ("down", "shown", "paint", "ws"))
        browser.close()
    rows = []
    for k in range(CHANGES):
        t0, t4 = down[k], shown[k]
        sends = [f for f in frames if f[0] == "send" and t0 <= f[1] <= t4]
        recvs = [f for f in frames if f[0] == "recv" and t0 <= f[1] <= t4]
        rows.append({"key": t0, "send": sends[0][1], "recv": recvs[-1][1], "dom": t4,
                     "paint": next(p for p in paint if p >= t4), "sends": len(sends), "recvs": len(recvs),
                     "bytes": sum(f[2] for f in recvs)})
    return rows, cpu, start


def server_parts(log: Path, start: float) -> list[dict]:
    """Per change on the server (s): receipt -> computation started, computed, shown (properties set and the patch
    serialised), written (its last PATCH-DOC message sent); the messages and their JSON bytes."""
    events = [e for e in map(json.loads, log.read_text().splitlines()) if e[0] >= start]
    parts, cur = [], None
    for e in events:
        if e[1] == "value":
            cur = {"in": e[0], "patches": 0, "json_bytes": 0, "nodelay": e[2]}
            parts.append(cur)
        elif cur is None:
            continue
        elif e[1] == "computed":
            cur["c0"], cur["c1"] = e[2], e[0]
        elif e[1] == "unheld":
            cur["shown"] = e[0]
        elif e[1] == "sent" and e[2] == "PATCH-DOC" and "shown" in cur:
            cur["written"], cur["patches"], cur["json_bytes"] = e[0], cur["patches"] + 1, cur["json_bytes"] + e[3]
    return [p for p in parts if "written" in p]


def main() -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "server.log"
        proc = subprocess.Popen([sys.executable, "-m", "benchmarks.explore_latency", "--serve", SCENE, str(log)],
                                cwd=tmp, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                env=os.environ | {"PYTHONPATH": str(Path(__file__).resolve().parents[1])})
        url = None
        for line in proc.stdout:
            if line.startswith("autobal explore: http"):
                url = line.split()[2]
                break
        if url is None:
            raise RuntimeError("the instrumented autobal explore printed no URL")
        threading.Thread(target=lambda: [None for _ in proc.stdout], daemon=True).start()
        try:
            rows, cpu, start = drive(url, log)
        finally:
            proc.terminate()
            proc.wait(timeout=30)
        srv = server_parts(log, start)
    ms = 1e-3  # browser times are ms

    def stage(name: str, values, note: str) -> dict:
        v = np.asarray(values, float)
        return case(name, float(np.percentile(v, 50)), None, None, None, p90_s=float(np.percentile(v, 90)),
                    note=note)

    server = [p["written"] - p["in"] for p in srv]
    # each change's own server time where every change was logged, else their median
    own = server if len(server) == len(rows) else [float(np.median(server))] * len(rows)
    transport = [(r["recv"] - r["send"]) * ms - s for r, s in zip(rows, own, strict=True)]
    cases = [
        stage("key press -> page updated (the browser test's latency)", [(r["dom"] - r["key"]) * ms for r in rows],
              "keydown to the update counter in the DOM"),
        stage("browser: key press -> change sent", [(r["send"] - r["key"]) * ms for r in rows],
              "the slider's keyboard handling"),
        stage("server: change received -> computation started", [p["c0"] - p["in"] for p in srv],
              "Bokeh applies the patch, the next tick"),
        stage("server: computation (DeviceExplorer.evaluate)", [p["c1"] - p["c0"] for p in srv],
              "Newton statics, Jacobian, eigenvalues, modal AFC, peaks"),
        stage("server: properties set, patch serialised (show, unhold)", [p["shown"] - p["c1"] for p in srv], ""),
        stage("server: patch written to the socket", [p["written"] - p["shown"] for p in srv], ""),
        stage("server: change received -> patch written", server, "the four server rows"),
        stage("transport: browser send -> patch received, less the server's part", transport,
              "websocket both ways (TCP_NODELAY) and queueing"),
        stage("browser: patch received -> page updated", [(r["dom"] - r["recv"]) * ms for r in rows],
              "BokehJS applies the patch, the Divs re-render"),
        stage("browser: page updated -> painted (after the latency's end point)",
              [(r["paint"] - r["dom"]) * ms for r in rows], "the plots' canvases at the next animation frame"),
    ]
    counts = {"browser_messages_per_change": float(np.median([r["sends"] for r in rows])) / 3,
              "server_patch_messages_per_change": float(np.median([p["patches"] for p in srv])),
              "frames_received_per_change": float(np.median([r["recvs"] for r in rows])),
              "bytes_received_per_change": float(np.median([r["bytes"] for r in rows]))}
    cpu_rows = [case(f"CPU per change: {k}", v, None, None, None) for k, v in sorted(cpu.items(), key=lambda x: -x[1])
                if v > 0]
    notes = [f"scene {SCENE}: {CHANGES} changes after {WARMUP} unmeasured, alternately "
             f"{' and '.join(SLIDERS)}, one arrow key each, 50 ms apart; autobal_s: the p50, p90_s: the p90",
             "messages per change: the browser sends {browser_messages_per_change:g} (3 frames each), the server "
             "{server_patch_messages_per_change:g} PATCH-DOC and an OK ({frames_received_per_change:g} frames, "
             "{bytes_received_per_change:.0f} bytes)".format(**counts),
             f"TCP_NODELAY on the server's websocket at every change: {all(p['nodelay'] for p in srv)}",
             "CPU per change: CPU time of each process over the changes / their number (the benchmark's own "
             "process and the Playwright driver included: they press the keys and wait)"]
    write("explore_latency", "autobal explore: where the time of one change goes (browser to browser)",
          cases + cpu_rows, notes)
    return cases


if __name__ == "__main__":
    if sys.argv[1:2] == ["--serve"]:
        serve(sys.argv[2], sys.argv[3])
    else:
        main()
