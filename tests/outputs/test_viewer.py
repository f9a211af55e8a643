"""A recording opens in the real Rerun web viewer (headless Chromium, software WebGL) without an error and
shows non-empty plots in the variants' colours. Runs only where Chromium and websocket-client are installed."""

from __future__ import annotations

import base64
import io
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
import urllib.parse
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.outputs.layout import variant_styles
from local_ports import free_port, listening

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
RERUN = shutil.which("rerun")
try:
    import websocket  # websocket-client
except ImportError:
    websocket = None

pytestmark = [pytest.mark.slow, pytest.mark.skipif(  # the viewer in a browser, a subprocess
    CHROMIUM is None or RERUN is None or websocket is None,
    reason="needs chromium (apt-get install chromium), the rerun command and websocket-client (pip install)")]

#: Pixels of a variant's colour that make a plot "non-empty" (a 1000-sample line in one plot is thousands).
MIN_PIXELS = 300


class _Page:
    """A Chromium tab driven over the DevTools protocol; collects console errors and page exceptions."""

    def __init__(self, url: str):
        self.ws = websocket.create_connection(url, timeout=60)
        self.counter = 0
        self.errors: list[str] = []

    def call(self, method: str, **params) -> dict:
        self.counter += 1
        self.ws.send(json.dumps({"id": self.counter, "method": method, "params": params}))
        while True:
            message = json.loads(self.ws.recv())
            if message.get("id") == self.counter:
                return message
            self._note(message)

    def _note(self, message: dict) -> None:
        params = message.get("params", {})
        if message.get("method") == "Runtime.exceptionThrown":
            self.errors.append(params["exceptionDetails"].get("text", "exception"))
        elif message.get("method") == "Runtime.consoleAPICalled" and params.get("type") == "error":
            self.errors.append(" ".join(str(a.get("value", a.get("description", ""))) for a in params["args"]))

    def screenshot(self) -> np.ndarray:
        from PIL import Image

        shot = self.call("Page.captureScreenshot", format="png")
        return np.asarray(Image.open(io.BytesIO(base64.b64decode(shot["result"]["data"]))).convert("RGB"))


def _colour_pixels(image: np.ndarray, hex_colour: str) -> int:
    rgb = np.array([int(hex_colour[i:i + 2], 16) for i in (1, 3, 5)])
    return int(np.count_nonzero(np.abs(image.astype(int) - rgb).max(axis=2) <= 12))


def test_recording_opens_in_the_web_viewer(tmp_path: Path) -> None:
    recording = tmp_path / "short.rrd"
    run = subprocess.run(["python", "-m", "ftc_mj.run", str(Path(__file__).parents[2] / "scenarios" / "puma_fault.yaml"),
                          "--duration", "1.0", "--quiet", "--out", str(recording)],
                         capture_output=True, text=True, timeout=300, env={**os.environ, "PYTHONPATH": os.getcwd()})
    assert run.returncode == 0, run.stderr
    web, grpc, debug = free_port(), free_port(), free_port()
    viewer = subprocess.Popen([RERUN, str(recording), "--web-viewer", "--bind", "127.0.0.1", "--web-viewer-port",
                               str(web), "--port", str(grpc)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              env={**os.environ, "BROWSER": "true"}, start_new_session=True)
    profile = tempfile.mkdtemp(prefix="viewer-test-")
    browser = None
    try:
        assert listening(web, 60), "the rerun web viewer did not start"
        # --remote-allow-origins: a current Chromium refuses the debugging websocket of a client that sends an
        # Origin header (as websocket-client does) unless that origin is allowed.
        browser = subprocess.Popen(
            [CHROMIUM, "--headless=new", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
             "--ignore-gpu-blocklist", "--window-size=1600,1000", f"--user-data-dir={profile}",
             f"--remote-debugging-port={debug}", "--remote-allow-origins=*", "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        tabs = None
        for _ in range(150):
            try:
                tabs = json.load(urllib.request.urlopen(f"http://127.0.0.1:{debug}/json"))
                break
            except OSError:
                time.sleep(0.2)
        assert tabs, "chromium did not start"
        page = _Page(next(t for t in tabs if t.get("type") == "page")["webSocketDebuggerUrl"])
        page.call("Runtime.enable")
        page.call("Page.enable")
        proxy = urllib.parse.quote(f"rerun+http://127.0.0.1:{grpc}/proxy", safe="")
        page.call("Page.navigate", url=f"http://127.0.0.1:{web}/?url={proxy}&renderer=webgl")
        # The first figure's tab (tracking error, every variant) shows once the data is in: wait for the
        # colours of the first two variants in the plots.
        colours = [style.color for style in variant_styles(["proposed", "nftsmc_tosmo"])]
        started = time.time()
        deadline, counts = started + 150, [0, 0]
        while time.time() < deadline:
            time.sleep(2)
            image = page.screenshot()
            counts = [_colour_pixels(image[:, image.shape[1] // 5:], c) for c in colours]  # right of the 3-D view
            if min(counts) >= MIN_PIXELS:
                break
        assert min(counts) >= MIN_PIXELS, f"plots look empty: pixels of {colours} = {counts}"
        # The viewer's own calls to the internet fail on an offline machine ("Failed to fetch"); nothing else may.
        errors = [e for e in page.errors if not e.startswith("TypeError: Failed to fetch")]
        assert not errors, errors
        print(f"plots shown after {time.time() - started:.0f} s: pixels {counts}")
    finally:
        for process in (browser, viewer):
            if process is not None:
                try:
                    os.killpg(process.pid, signal.SIGTERM)
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    os.killpg(process.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        shutil.rmtree(profile, ignore_errors=True)
