"""``ftc-mj run --connect URL``: the recording goes to a viewer's gRPC server as well as to ``--out``. The server
is ``rerun --port P --save FILE`` started here (headless: it saves what it receives), skipped where the
``rerun`` program is missing."""

from __future__ import annotations

import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from ftc_mj.cli.run import main
from ftc_mj.outputs.recording import read_entities, read_layout

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "puma_fault.yaml"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _listening(port: int, seconds: float) -> bool:
    deadline = time.time() + seconds
    while time.time() < deadline:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return True
        time.sleep(0.2)
    return False


@pytest.mark.filterwarnings("ignore:RRD file has no footer")  # a stream saved by the server, not a file
@pytest.mark.skipif(shutil.which("rerun") is None, reason="the rerun program (rerun-sdk) is not on PATH")
def test_connect_streams_the_recording_to_a_grpc_server_and_keeps_the_file(tmp_path):
    port, received, file = _free_port(), tmp_path / "received.rrd", tmp_path / "run.rrd"
    server = subprocess.Popen(["rerun", "--port", str(port), "--save", str(received)], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        assert _listening(port, 60), "the rerun gRPC server did not start"
        url = f"rerun+http://127.0.0.1:{port}/proxy"
        assert main([str(SCENARIO), "--duration", "0.05", "--variant", "proposed", "--out", str(file), "--quiet",
                     "--connect", url]) == 0
        time.sleep(2)  # let the server write what it received
    finally:
        server.send_signal(signal.SIGINT)
        try:
            server.wait(timeout=20)
        except subprocess.TimeoutExpired:
            server.kill()
    entity = "/tracking_error/joint1"
    assert [s.name for s in read_layout(received).variants] == ["proposed"]
    sent, kept = read_entities(received, {entity})[entity], read_entities(file, {entity})[entity]
    np.testing.assert_array_equal(sent[1], kept[1])
    assert len(kept[0]) == 50


def test_a_viewer_needs_a_recording(tmp_path, capsys):
    assert main([str(SCENARIO), "--duration", "0.01", "--no-record", "--connect"]) == 2
    assert capsys.readouterr().err.strip() == ("error: command line: --connect: sends the recording to a viewer: "
                                               "drop --no-record")
