"""``ftc-mj run --connect URL``: the run streams to a viewer's gRPC server while it runs, blueprint first and
chunk by chunk, and ends with what the file has, as well as ``--out``. The server is ``rerun --port P --save
FILE`` started here (headless: it saves what it receives), skipped where the ``rerun`` program is missing."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

from ftc_mj.cli.run import main
from ftc_mj.outputs import live
from ftc_mj.outputs.recording import read_entities, read_layout
from local_ports import free_port, listening

RERUN = shutil.which("rerun")
SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "puma_fault.yaml"


class _Server:
    """``rerun --port P --save FILE``: a gRPC server that saves what it receives."""

    def __init__(self, received: Path):
        self.port = free_port()
        self.process = subprocess.Popen([RERUN, "--port", str(self.port), "--save", str(received)],
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        self.url = f"rerun+http://127.0.0.1:{self.port}/proxy"

    def __enter__(self) -> "_Server":
        assert listening(self.port, 60), "the rerun gRPC server did not start"
        return self

    def __exit__(self, *exc: object) -> None:
        time.sleep(2)  # let the server write what it received
        os.killpg(self.process.pid, signal.SIGINT)  # the rerun script and the viewer binary it starts
        try:
            self.process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)


def _first_store(path: Path) -> str:
    """The kind of the first store a recording's messages open (``Blueprint`` or ``Recording``)."""
    printed = subprocess.run([RERUN, "rrd", "print", str(path)], capture_output=True, text=True, timeout=120).stdout
    lines = printed.splitlines()
    return next(lines[i + 1].strip().rstrip(",") for i, line in enumerate(lines) if "StoreId(" in line)


@pytest.mark.slow  # a closed-loop run of seconds
@pytest.mark.filterwarnings("ignore:RRD file has no footer")  # a stream saved by the server, not a file
@pytest.mark.skipif(RERUN is None, reason="the rerun program (rerun-sdk) is not on PATH")
def test_connect_streams_the_recording_to_a_grpc_server_and_keeps_the_file(tmp_path):
    received, file = tmp_path / "received.rrd", tmp_path / "run.rrd"
    with _Server(received) as server:
        assert main([str(SCENARIO), "--duration", "0.05", "--variant", "proposed", "--out", str(file), "--quiet",
                     "--connect", server.url]) == 0
    entity = "/tracking_error/joint1"
    assert [s.name for s in read_layout(received).variants] == ["proposed"]
    sent, kept = read_entities(received, {entity})[entity], read_entities(file, {entity})[entity]
    np.testing.assert_array_equal(sent[1], kept[1])
    assert len(kept[0]) == 50


@pytest.mark.slow  # a subprocess
@pytest.mark.filterwarnings("ignore:RRD file has no footer")
@pytest.mark.skipif(RERUN is None, reason="the rerun program (rerun-sdk) is not on PATH")
def test_the_run_streams_blueprint_first_then_chunk_by_chunk(tmp_path, monkeypatch):
    monkeypatch.setattr(live, "SEND_INTERVAL", 0.0)  # send at every chunk of the loop
    received, file = tmp_path / "received.rrd", tmp_path / "run.rrd"
    with _Server(received) as server:
        assert main([str(SCENARIO), "--duration", "1.2", "--out", str(file), "--quiet", "--connect", server.url]) == 0
    assert _first_store(received) == "Blueprint"
    streamed = [c for c in RrdReader(received).stream().to_chunks() if c.entity_path == "/q/joint1" and not c.is_static]
    # The loop's hook every 500 periods, then the last 200 samples after the run.
    assert sorted(c.num_rows for c in streamed) == [200, 500, 500]
    entities = {"/q/joint1", "/tracking_error/joint2", "/velocity/estimate/joint3", "/luaf_error/joint1",
                "/fault_active"}
    sent, kept = read_entities(received, entities), read_entities(file, entities)
    assert set(sent) == set(kept) == entities
    for entity in kept:  # the viewer sees the file's values: streamed ones and those computed after the run
        np.testing.assert_array_equal(sent[entity][0], kept[entity][0])
        np.testing.assert_array_equal(sent[entity][1], kept[entity][1])
    poses = [sum(c.num_rows for c in RrdReader(path).stream().to_chunks()
                 if c.entity_path == "/world/link1" and not c.is_static) for path in (received, file)]
    assert poses[0] == poses[1] == 121  # every 10th sample and the last
    assert read_entities(received, {"/velocity/estimate/joint1"})["/velocity/estimate/joint1"][1].shape[1] == len(
        read_layout(file).variants)


def test_a_viewer_needs_a_recording(tmp_path, capsys):
    assert main([str(SCENARIO), "--duration", "0.01", "--no-record", "--connect"]) == 2
    assert capsys.readouterr().err.strip() == ("error: command line: --connect: sends the recording to a viewer: "
                                               "drop --no-record")
