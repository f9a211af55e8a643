"""Hostile inputs through the command lines (``ftc-mj run|figures|campaign|tune``), one per row of
:data:`CASES`: YAML structure (alias bombs, deep nesting, oversized files), special files (devices, pipes,
directories), outputs (an input overwritten, a kernel file system, a device node), numbers (seeds beyond 64
bits, a reference that is NaN on the run's grid), names (a signal no method records), campaigns and tuning
(a claim or a variant that does not exist, a scheduler where nothing listens, optimizer bounds, a results
directory another process holds), robots (a URDF without links; what a robot file may cost: links, bodies,
replicated elements; a mesh behind a loop of links), calibration (its output against every input, its run
count, runs too short to measure a false alarm), live viewing (no viewer at --connect's address, --serve's
port in use), logs (damaged messages, a bag's metadata that is not UTF-8, a joint or a column named twice),
a bench resumed from damaged results, and a report of a document that is not one.

Each case must exit 2 with one line on stderr that names the file and the field, print no traceback, write
nothing (the folder's listing and every input's bytes are the same afterwards) and end within
:data:`TIMEOUT` (its process is killed then: the cases that hung took minutes and gigabytes) under an
address-space limit of :data:`MEMORY_KB`. Each case is a process of its own, forked from one driver
subprocess that imported the package once (:func:`drive`).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "campaign"))
sys.path.insert(0, str(ROOT / "tests" / "logs"))
import log_files  # noqa: E402
import small_campaign  # noqa: E402

#: closed-loop runs and subprocesses of the command line
pytestmark = pytest.mark.slow

#: Seconds a case may take, on a loaded machine (before the fixes: minutes, or killed by the memory limit).
TIMEOUT = 15
#: Address space of a case [KiB]: an expanded alias bomb or /dev/zero read whole would exceed it.
MEMORY_KB = 3_000_000
BOMB = "\n".join(["  a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
                 + [f"  a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, 9)]) + "\n"


def scenario(**changes) -> dict:
    data = small_campaign.scenario()
    data.update(changes)
    return data


def dump(data: dict) -> str:
    return yaml.safe_dump(data, sort_keys=False)


@dataclass
class Case:
    """``setup(folder)`` writes the inputs and returns the command's arguments after ``ftc-mj``; the one
    stderr line must contain ``file`` (a name in the folder, or a path) and ``field``."""

    name: str
    setup: Callable[[Path], list[str]]
    file: str
    field: str
    root_only: bool = False


def run_case(scenario_text: str | Callable[[Path], str], *extra: str) -> Callable[[Path], list[str]]:
    def setup(folder: Path) -> list[str]:
        text = scenario_text(folder) if callable(scenario_text) else scenario_text
        (folder / "s.yaml").write_text(text)
        return ["run", "s.yaml", "--duration", "0.05", "--quiet", *extra] + (
            [] if "--out" in extra or "--no-record" in extra else ["--out", "rec.rrd"]) + (
            [] if "--json" in extra else ["--json", "out.json"])
    return setup


def with_model(name: str) -> Callable[[Path], str]:
    def text(folder: Path) -> str:
        data = scenario()
        data["robot"]["model"] = name if name != "DIR" else str(folder / "models")
        (folder / "models").mkdir(exist_ok=True)
        return dump(data)
    return text


def fifo_scenario(folder: Path) -> list[str]:
    os.mkfifo(folder / "pipe.yaml")
    return ["run", "pipe.yaml", "--quiet", "--out", "rec.rrd"]


def local_model(folder: Path) -> list[str]:
    (folder / "m.xml").write_bytes((ROOT / "models" / "puma560.xml").read_bytes())
    data = scenario()
    data["robot"]["model"] = "m.xml"
    (folder / "s.yaml").write_text(dump(data))
    return ["run", "s.yaml", "--quiet", "--duration", "0.05", "--out", "m.xml"]


def with_base(folder: Path) -> list[str]:
    (folder / "base.yaml").write_text(dump(scenario()))
    (folder / "s.yaml").write_text("base: base.yaml\nname: child\n")
    return ["run", "s.yaml", "--quiet", "--duration", "0.05", "--json", "base.yaml", "--no-record"]


def device_output(folder: Path) -> list[str]:
    os.mknod(folder / "null", 0o020666, os.makedev(1, 3))
    (folder / "s.yaml").write_text(dump(scenario()))
    return ["run", "s.yaml", "--quiet", "--duration", "0.05", "--out", "null"]


def mutated(dotted: str, value) -> str:
    data = scenario()
    *parents, last = dotted.split(".")
    node = data
    for part in parents:
        node = node[int(part)] if isinstance(node, list) else node[part]
    node[int(last) if isinstance(node, list) else last] = value
    return dump(data)


def campaign_case(change: Callable[[dict], None] | str, *extra: str) -> Callable[[Path], list[str]]:
    def setup(folder: Path) -> list[str]:
        path = small_campaign.write(folder, campaign_changes={"duration": 0.3})
        if callable(change):
            data = yaml.safe_load(path.read_text())
            change(data)
            path.write_text(dump(data))
        else:
            path.write_text(path.read_text() + change)
        return ["campaign", "run", path.name, "--quiet", "--workers", "1", *extra] + (
            [] if "--out" in extra else ["--out", "results"])
    return setup


def set_claim(data: dict) -> None:
    data["report"]["claims"][0]["worse"] = "nope"


def tuning_case(optimizer: dict) -> Callable[[Path], list[str]]:
    def setup(folder: Path) -> list[str]:
        small_campaign.write(folder)
        (folder / "tuning.yaml").write_text(dump({
            "name": "t", "campaign": "campaign.yaml", "variant": "hs", "conditions": 2, "held_out": 2,
            "gains": {"variants.hs.controller.gains.mu": {"low": 0.1, "high": 1.0}},
            "cost": {"weights": {"rms_error_converged": 1.0}},
            "optimizer": {"population": 4, "generations": 1, "sigma": 0.2, "seed": 0, **optimizer}}))
        return ["tune", "tuning.yaml", "--quiet", "--workers", "1", "--out", "results"]
    return setup


def tuning_variant(folder: Path) -> list[str]:
    argv = tuning_case({})(folder)
    data = yaml.safe_load((folder / "tuning.yaml").read_text())
    data.update(variant="nope", gains={"variants.nope.controller.gains.mu": {"low": 0.1, "high": 1.0}})
    (folder / "tuning.yaml").write_text(dump(data))
    return argv


def locked_tuning(folder: Path) -> list[str]:
    """A tuning whose --out another live process holds locked (as a running tuning or campaign does)."""
    argv = tuning_case({})(folder)
    (folder / "results").mkdir()
    (folder / "results" / "lock").touch()
    holder = subprocess.Popen([sys.executable, "-c", "import fcntl, sys, time; handle = open(sys.argv[1], 'a+'); "
                               "fcntl.flock(handle, fcntl.LOCK_EX); print('held', flush=True); time.sleep(60)",
                               str(folder / "results" / "lock")], stdout=subprocess.PIPE)
    assert holder.stdout.readline().strip() == b"held"
    HOLDERS.append(holder)
    return argv


#: The processes that hold a lock for a case, ended when the corpus has run.
HOLDERS: list[subprocess.Popen] = []


def urdf_case(text: str) -> Callable[[Path], list[str]]:
    def setup(folder: Path) -> list[str]:
        (folder / "robot.urdf").write_text(text)
        return run_case(mutated("robot.model", "robot.urdf"))(folder)
    return setup


def calibrate_near_the_largest_seed(folder: Path) -> list[str]:
    """The healthy runs start at the scenario's seed + 1000: beyond the largest seed."""
    (folder / "s.yaml").write_text(dump(scenario(seed=2**63 - 100)))
    return ["calibrate", "s.yaml", "--false-alarm-rate", "0.1", "--runs", "3", "--out", "c.yaml"]


# ------------------------------------------------------------------ calibrate: outputs, numbers, windows


def calibrate_case(out: str | None, *extra: str, model: bool = False) -> Callable[[Path], list[str]]:
    """``calibrate s.yaml`` where s.yaml inherits base.yaml (and with ``model`` a model file in the folder);
    ``out``: its --out (``LINK``: a symbolic link to s.yaml)."""
    def setup(folder: Path) -> list[str]:
        data = scenario(duration=0.3)
        if model:
            (folder / "m.xml").write_bytes((ROOT / "models" / "puma560.xml").read_bytes())
            data["robot"]["model"] = "m.xml"
        (folder / "base.yaml").write_text(dump(data))
        (folder / "s.yaml").write_text("base: base.yaml\nname: child\n")
        target = out
        if out == "LINK":
            (folder / "link.yaml").symlink_to("s.yaml")
            target = "link.yaml"
        return ["calibrate", "s.yaml", "--false-alarm-rate", "0.1", "--runs", "3", *extra] + (
            [] if target is None else ["--out", target])
    return setup


# ------------------------------------------------------------------ live viewing


def port_in_use(folder: Path) -> list[str]:
    """--serve on a port another live process listens on."""
    holder = subprocess.Popen([sys.executable, "-c", "import socket, time; s = socket.socket(); "
                               "s.bind(('127.0.0.1', 0)); s.listen(); print(s.getsockname()[1], flush=True); "
                               "time.sleep(60)"], stdout=subprocess.PIPE)
    port = int(holder.stdout.readline())
    HOLDERS.append(holder)
    return run_case(dump(scenario()), "--serve", "--bind", f"127.0.0.1:{port}")(folder)


# ------------------------------------------------------------------ robot files: cost, links


def mesh_loop(folder: Path) -> list[str]:
    (folder / "loop1.stl").symlink_to("loop2.stl")
    (folder / "loop2.stl").symlink_to("loop1.stl")
    text = (ROOT / "models" / "puma560.urdf").read_text()
    text = text.replace("</link>", '<visual><geometry><mesh filename="loop1.stl"/></geometry></visual></link>', 1)
    return urdf_case(text)(folder)


def many_links(count: int) -> str:
    links = "".join(f'<link name="l{k}"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" '
                    'iyz="0" izz="1"/></inertial></link>' for k in range(count))
    joints = "".join(f'<joint name="j{k}" type="revolute"><parent link="l{k}"/><child link="l{k + 1}"/>'
                     '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
                     for k in range(count - 1))
    return f'<robot name="long">{links}{joints}</robot>\n'


def mjcf_case(text: str) -> Callable[[Path], list[str]]:
    def setup(folder: Path) -> list[str]:
        (folder / "robot.xml").write_text(text)
        return run_case(mutated("robot.model", "robot.xml"))(folder)
    return setup


REPLICATED = """<mujoco><worldbody><replicate count="100000" offset="0 0 0.01">
<body><joint type="hinge"/><geom size="0.01" mass="1"/></body></replicate></worldbody></mujoco>
"""
NESTED_REPLICATES = """<mujoco><worldbody><replicate count="100" offset="0 0 0.01"><replicate count="100" offset="0.01 0 0">
<body><geom size="0.01"/></body></replicate></replicate></worldbody></mujoco>
"""


# ------------------------------------------------------------------ logs: damaged, ambiguous


def log_case(write: Callable[[Path], dict], *extra: str) -> Callable[[Path], list[str]]:
    """A replay of the log ``write(folder)`` writes (returning the ``log`` section)."""
    def setup(folder: Path) -> list[str]:
        log_files.log_scenario(folder, write(folder), duration=0.5)
        return ["run", "replay.yaml", "--quiet", "--no-record", *extra] + (
            [] if "--json" in extra else ["--json", "out.json"])
    return setup


def csv_repeated_column(folder: Path) -> dict:
    t, q, qd, tau = log_files.trajectory()
    log_files.write_csv(folder / "log.csv", t, q, qd, tau)
    text = (folder / "log.csv").read_text().replace("t,q1,q2,qd1,qd2,i1,i2", "t,q1,q1,qd1,qd2,i1,i2", 1)
    (folder / "log.csv").write_text(text)
    return {**log_files.CSV_LOG, "file": "log.csv"}


def joint_states(names=("joint1", "joint2"), damaged: int | None = None) -> list[tuple[str, int, bytes]]:
    messages = []
    for k in range(60):
        data = log_files.joint_state(list(names), [0.01 * k] * len(names), (), [1.0] * len(names), k * 10**7)
        messages.append(("/joint_states", k * 10**7, data[:len(data) // 2] if k == damaged else data))
    return messages


def joint_state_log(form: str, **options) -> Callable[[Path], dict]:
    def write(folder: Path) -> dict:
        if form == "mcap":
            log_files.write_mcap(folder / "log.mcap", joint_states(**options))
            return {"format": "mcap", "file": "log.mcap", "topic": "/joint_states", "joints": ["joint1", "joint2"],
                    "steps": {"resample": 0.01}}
        log_files.write_bag(folder / "bag", joint_states(**options))
        return {"format": "rosbag2", "file": "bag", "topic": "/joint_states", "joints": ["joint1", "joint2"],
                    "steps": {"resample": 0.01}}
    return write


def bag_metadata_not_utf8(folder: Path) -> dict:
    section = joint_state_log("rosbag2")(folder)
    metadata = folder / "bag" / "metadata.yaml"
    metadata.write_bytes(metadata.read_bytes().replace(b"joint_states", b"joint_\xff\xfestates", 1))
    return section


# ------------------------------------------------------------------ bench: resuming from damaged results


def damaged_bench(folder: Path) -> list[str]:
    manifest = folder / "results" / "runs" / "diagnosis" / "two_link" / "healthy" / "abc" / "entries.json"
    manifest.parent.mkdir(parents=True)
    manifest.write_text('{"protocol": "x", "entr')
    return ["bench", "--out", "results", "--quiet", "--workers", "1"]


def report_of(text: str) -> Callable[[Path], list[str]]:
    def setup(folder: Path) -> list[str]:
        (folder / "m.json").write_text(text)
        return ["report", "m.json"]
    return setup



def figures_case(recording: str, *extra: str) -> Callable[[Path], list[str]]:
    def setup(folder: Path) -> list[str]:
        (folder / "rec.rrd").write_bytes(b"not a recording")
        return ["figures", recording, *extra]
    return setup


CASES = [
    # YAML structure
    Case("alias bomb in an unknown key", run_case(dump(scenario()) + "junk:\n" + BOMB), "s.yaml", "line "),
    Case("alias bomb in description", run_case(dump({k: v for k, v in scenario().items()}) + "description:\n" + BOMB),
         "s.yaml", "line "),
    Case("deeply nested list", run_case(dump(scenario()) + "junk: " + "[" * 50000 + "]" * 50000 + "\n"),
         "s.yaml", "line "),
    Case("deeply nested mapping", run_case(dump(scenario()) + "junk: " + "{a: " * 20000 + "1" + "}" * 20000 + "\n"),
         "s.yaml", "line "),
    Case("oversized file", run_case(dump(scenario()) + "description: " + "x" * (2 << 20) + "\n"), "s.yaml",
         "larger than"),
    # special files
    Case("scenario is /dev/zero", lambda folder: ["run", "/dev/zero", "--quiet", "--out", "rec.rrd"], "/dev/zero",
         "not a regular file"),
    Case("scenario is a named pipe", fifo_scenario, "pipe.yaml", "not a regular file"),
    Case("model is a directory", run_case(with_model("DIR")), "s.yaml", "robot.model: model file"),
    Case("model is a device", run_case(with_model("/dev/null")), "s.yaml", "robot.model: model file '/dev/null' is not"),
    # outputs
    Case("--out is the scenario", run_case(dump(scenario()), "--out", "s.yaml"), "s.yaml", "--out"),
    Case("--json is the scenario", run_case(dump(scenario()), "--no-record", "--json", "s.yaml"), "s.yaml", "--json"),
    Case("--out is the model file", local_model, "s.yaml", "--out"),
    Case("--json is a base", with_base, "s.yaml", "--json"),
    Case("--out is on /proc", run_case(dump(scenario()), "--out", "/proc/self/x.rrd"), "s.yaml", "--out"),
    Case("--json is on /sys", run_case(dump(scenario()), "--no-record", "--json", "/sys/kernel/x.json"), "s.yaml",
         "--json"),
    Case("--out is a device node", device_output, "s.yaml", "--out", root_only=True),
    Case("--out and --json are one file", run_case(dump(scenario()), "--out", "x", "--json", "x"), "s.yaml",
         "--json"),
    # numbers
    Case("seed beyond 64 bits", run_case(dump(scenario(seed=2**70))), "s.yaml", "seed"),
    Case("--set seed beyond 64 bits", run_case(dump(scenario()), "--set", f"seed={2**70}"), "s.yaml", "seed"),
    Case("reference NaN on the grid", run_case(mutated("reference.0", "log(t - 5)")), "s.yaml", "reference.0"),
    Case("reference infinite on the grid", run_case(mutated("reference.1", "1/(t - 0.02)")), "s.yaml", "reference.1"),
    Case("reference derivative infinite at 0", run_case(mutated("reference.2", "sqrt(t)")), "s.yaml", "reference.2"),
    Case("term of time NaN while on", run_case(mutated("terms.1.value.1", "sqrt(t - 1) * size").replace(
        "onset: 0.3", "onset: 0.01")), "s.yaml", "terms.1.value.1"),
    # names
    Case("extras.__dict__", run_case(dump(scenario(figures=[{"name": "x", "quantity": "extras.__dict__"}]))),
         "s.yaml", "figures.0"),
    Case("a signal no method records", run_case(dump(scenario(figures=[{"name": "x", "quantity": "extras.nothing"}]))),
         "s.yaml", "figures.0.quantity"),
    # figures
    Case("figures of /dev/zero", figures_case("/dev/zero", "--out", "figs"), "/dev/zero", "not a regular file"),
    Case("figures --out is the recording", figures_case("rec.rrd", "--out", "rec.rrd"), "rec.rrd", "--out"),
    Case("figures --out on /proc", figures_case("rec.rrd", "--out", "/proc/self/figs"), "rec.rrd", "--out"),
    # campaigns and tuning
    Case("claim on an unknown variant", campaign_case(set_claim), "campaign.yaml", "report.claims.0.worse"),
    Case("campaign seed beyond 64 bits", campaign_case(lambda data: data.update(seed=2**70)), "campaign.yaml", "seed"),
    Case("campaign alias bomb", campaign_case("junk:\n" + BOMB), "campaign.yaml", "line "),
    Case("campaign --out is the campaign", campaign_case(lambda data: None, "--out", "campaign.yaml"), "campaign.yaml",
         "--out"),
    Case("--scheduler not an address", campaign_case(lambda data: None, "--scheduler", "not an address"),
         "campaign.yaml", "--scheduler"),
    Case("--scheduler where nothing listens", campaign_case(lambda data: None, "--scheduler", "tcp://127.0.0.1:1"),
         "campaign.yaml", "--scheduler"),
    Case("optimizer.sigma NaN", tuning_case({"sigma": float("nan")}), "tuning.yaml", "optimizer.sigma: Input should be a finite"),
    Case("optimizer.population 1", tuning_case({"population": 1}), "tuning.yaml", "optimizer.population"),
    Case("optimizer.seed beyond 32 bits", tuning_case({"seed": 2**40}), "tuning.yaml", "optimizer.seed"),
    Case("campaign variant unknown", campaign_case(lambda data: data.update(variants=["hs", "nope"])),
         "campaign.yaml", "variants.1: unknown variant 'nope'"),
    Case("tuning variant unknown", tuning_variant, "tuning.yaml", "variant: unknown variant 'nope'"),
    Case("tuning --out held by a live process", locked_tuning, "tuning.yaml", "--out"),
    # robots
    Case("URDF without links", urdf_case('<robot name="empty"></robot>\n'), "robot.urdf", "<robot>: has no <link>"),
    # numbers: seeds derived from the scenario's
    Case("calibrate seeds beyond 64 bits", calibrate_near_the_largest_seed, "s.yaml", "seed: the healthy runs' seeds"),
    # calibrate: outputs against every input, numbers, windows
    Case("calibrate --out is the scenario", calibrate_case("s.yaml"), "s.yaml", "--out: 's.yaml' is an input"),
    Case("calibrate --out is the base", calibrate_case("base.yaml"), "s.yaml", "--out: 'base.yaml' is an input"),
    Case("calibrate --out is the model", calibrate_case("m.xml", model=True), "s.yaml", "--out: 'm.xml' is an input"),
    Case("calibrate --out links to the scenario", calibrate_case("LINK"), "s.yaml", "--out: 'link.yaml' is an input"),
    Case("calibrate --out /dev/full", calibrate_case("/dev/full"), "s.yaml", "--out: '/dev/full' is not a regular"),
    Case("calibrate --runs a billion", calibrate_case("c.yaml", "--runs", "1000000000"), "s.yaml",
         "--runs: must be 2 to 10000"),
    Case("calibrate runs end before the diagnoser is armed", calibrate_case("c.yaml", "--duration", "0.2"),
         "s.yaml", "duration: the runs end at 0.2 s"),
    # outputs against each other
    Case("--json is an exported log", run_case(dump(scenario()), "--json", "out.hs.csv", "--export-log", "out.csv"),
         "s.yaml", "--export-log: 'out.hs.csv' is also the path of --json"),
    Case("--out is an exported log", run_case(dump(scenario()), "--out", "out.hs.csv", "--export-log", "out.csv"),
         "s.yaml", "--export-log: 'out.hs.csv' is also the path of --out"),
    Case("--export is the --json file", run_case(dump(scenario()), "--json", "out.csv", "--export", "out.csv"),
         "s.yaml", "--export: 'out.csv' is also the path of --json"),
    Case("--export of an unknown form", run_case(dump(scenario()), "--export", "out.xlsx"), "s.yaml",
         "--export: 'out.xlsx': the extension must be one of .mat, .parquet, .csv"),
    Case("--json inside the replayed bag", log_case(joint_state_log("rosbag2"), "--json", "bag/m.json"),
         "replay.yaml", "--json: 'bag/m.json' is inside an input folder"),
    # live viewing
    Case("--connect where no viewer listens", run_case(dump(scenario()), "--connect", "rerun+http://127.0.0.1:1/proxy"),
         "command line", "--connect: no viewer at rerun+http://127.0.0.1:1/proxy"),
    Case("--connect not a viewer's address", run_case(dump(scenario()), "--connect", "http://x"), "command line",
         "--connect: 'http://x' is not a viewer's address"),
    Case("--serve on a port in use", port_in_use, "command line", "--serve: cannot listen on 127.0.0.1:"),
    Case("--bind without --serve", run_case(dump(scenario()), "--bind", "0.0.0.0"), "command line",
         "--bind: is the address --serve listens on"),
    # robot files: what they may cost
    Case("mesh behind a loop of symbolic links", mesh_loop, "robot.urdf", "mesh: "),
    Case("URDF of 100,000 links", urdf_case(many_links(100_000)), "robot.urdf", "more than the 1000 a robot file may "
         "have (MAX_LINKS)"),
    Case("MJCF replicate count 100,000", mjcf_case(REPLICATED), "s.yaml", "robot.model: robot.xml has more than "
         "1000 bodies"),
    Case("MJCF nested replicates", mjcf_case(NESTED_REPLICATES), "s.yaml", "(MAX_BODIES)"),
    # logs: damaged, ambiguous
    Case("CSV header repeats a column", log_case(csv_repeated_column), "log.csv", "log.columns.position.0: the "
         "header names 2 columns 'q1'"),
    Case("JointState names a joint twice", log_case(joint_state_log("mcap", names=("joint1", "joint2", "joint1"))),
         "log.mcap", "log.joints: message 0 on '/joint_states' names the joint 'joint1' twice"),
    Case("MCAP message damaged", log_case(joint_state_log("mcap", damaged=7)), "log.mcap",
         "log.topic: message 7 on '/joint_states' cannot be decoded"),
    Case("rosbag2 message damaged", log_case(joint_state_log("rosbag2", damaged=7)), "bag",
         "log.topic: message 7 on '/joint_states' cannot be decoded"),
    Case("bag metadata not UTF-8", log_case(bag_metadata_not_utf8), "bag", "log.file: is not a readable rosbag2 bag"),
    # bench: resuming from damaged results
    Case("bench resumes from a damaged entries.json", damaged_bench, "entries.json", "cannot be read (truncated or "
         "damaged"),
    # report
    Case("report of a JSON that is not a document of metrics", report_of('{"variants": {}}'), "m.json",
         "not a metrics JSON"),
]


@dataclass
class Outcome:
    returncode: int | str
    stderr: str
    before: dict[str, bytes | None]
    after: dict[str, bytes | None]


def listing(folder: Path) -> dict[str, bytes | None]:
    """Every entry below ``folder`` with its bytes (None: not a regular file)."""
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() and not p.is_symlink() else None
            for p in sorted(folder.rglob("*"))}


# ------------------------------------------------------------------------------------------------ the driver
# One subprocess imports the package once, then runs each case in a forked child of its own (the command's
# main(argv), its working directory the case's folder, stderr to a file, an address-space limit), killed at
# TIMEOUT: a real process per case and its exit status, without paying the imports 37 times.


def _child(argv: list[str], folder: str, stderr_path: str) -> None:
    import resource
    import traceback

    from ftc_mj.cli.main import main

    os.chdir(folder)
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_KB * 1024, MEMORY_KB * 1024))
    handle = os.open(stderr_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(handle, 2)
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    except BaseException:  # noqa: BLE001 - what the command would print: a traceback, exit 1
        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def drive(jobs_path: str) -> None:
    """Run the jobs of ``jobs_path`` (JSON: argv, folder, stderr file), two at a time; write each exit status
    (or "timeout") beside them."""
    import json
    import signal
    import time

    import ftc_mj.campaign.execute  # noqa: F401 - the imports every command needs, paid once
    import ftc_mj.cli.calibrate  # noqa: F401
    import ftc_mj.cli.campaign  # noqa: F401
    import ftc_mj.cli.report  # noqa: F401
    import ftc_mj.logs.readers  # noqa: F401
    import ftc_mj.outputs.live  # noqa: F401
    import ftc_mj.ranking.leaderboard  # noqa: F401
    import ftc_mj.cli.figures  # noqa: F401
    import ftc_mj.cli.run  # noqa: F401
    import ftc_mj.cli.tune  # noqa: F401
    import ftc_mj.outputs.recording  # noqa: F401
    import ftc_mj.tuning.optimise  # noqa: F401
    import rich.console  # noqa: F401

    jobs = json.loads(Path(jobs_path).read_text())
    codes: dict[int, int | str] = {}
    running: dict[int, tuple[int, float]] = {}
    pending = list(range(len(jobs)))
    while pending or running:
        while pending and len(running) < 2:
            index = pending.pop(0)
            sys.stdout.flush()
            sys.stderr.flush()
            pid = os.fork()
            if pid == 0:
                _child(*jobs[index])
            running[index] = (pid, time.monotonic() + TIMEOUT)
        for index, (pid, deadline) in list(running.items()):
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                codes[index] = os.waitstatus_to_exitcode(status)
                del running[index]
            elif time.monotonic() > deadline:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                codes[index] = "timeout"
                del running[index]
        time.sleep(0.02)
    Path(jobs_path).with_suffix(".codes").write_text(json.dumps([codes[i] for i in range(len(jobs))]))


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory) -> dict[str, Outcome]:
    import json

    base = tmp_path_factory.mktemp("bad_input")
    chosen = [case for case in CASES if not case.root_only or os.geteuid() == 0]
    jobs, befores = [], []
    for index, case in enumerate(chosen):
        folder = base / f"case{index}"
        folder.mkdir()
        argv = case.setup(folder)
        befores.append(listing(folder))
        jobs.append([argv, str(folder), str(base / f"case{index}.stderr")])
    jobs_path = base / "jobs.json"
    jobs_path.write_text(json.dumps(jobs))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    try:
        subprocess.run([sys.executable, __file__, str(jobs_path)], env=env, check=True,
                       timeout=60 + TIMEOUT * len(jobs))
    finally:
        for holder in HOLDERS:
            holder.kill()
            holder.wait()
    codes = json.loads(jobs_path.with_suffix(".codes").read_text())
    return {case.name: Outcome(code, Path(job[2]).read_text() if Path(job[2]).exists() else "", before,
                               listing(Path(job[1])))
            for case, job, code, before in zip(chosen, jobs, codes, befores)}


@pytest.mark.parametrize("case", CASES, ids=[case.name for case in CASES])
def test_refused_in_one_line_with_nothing_written(outcomes, case):
    if case.name not in outcomes:
        pytest.skip("needs root (mknod)")
    outcome = outcomes[case.name]
    assert outcome.returncode == 2, outcome.stderr[-2000:]
    lines = outcome.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in outcome.stderr, outcome.stderr[-2000:]
    assert case.file in lines[0] and case.field in lines[0], lines[0]
    assert outcome.after == outcome.before, "something was written or an input changed"


if __name__ == "__main__":
    drive(sys.argv[1])
