"""Identify a robot's joint friction (and, with enough excitation, its inertial parameters and armature) from
logs: ``ftc-mj identify LOG... (--only friction | --all) --out FILE.yaml [--robot ROBOT] [--validate LOG...]``.

Each LOG is a scenario file with a ``log`` section (it says how to read the log and which robot it is of).
Least squares on the joint-torque regressor of the robot's MuJoCo model, on zero-phase filtered velocity and
acceleration (:mod:`ftc_mj.robot.identify`): ``--only friction`` fits viscous, Coulomb and offset friction per
joint with the model's rigid body kept; ``--all`` fits the base parameters (QR), armature and friction, and is
refused where the excitation report says the logs cannot support it. Writes FILE.yaml, a file a scenario names
as its ``base:`` (``nominal.friction``; with ``--all`` also ``robot.model``, an MJCF FILE.xml beside it holding
the identified bodies and armature); with ``--base SCENARIO``, a runnable scenario: SCENARIO with
the identified parameters. ``--validate`` prints the torque residual RMS per joint on logs not used for the
fit. A log's labelled events (``log.events``: pushes, contacts) are left out of both.

Exit status: 0 on success, 2 on bad input (one line naming the file and the problem; nothing written).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ftc_mj.cli.command import Outputs, exit_status
from ftc_mj.cli.parser import ArgumentParser

PROG = "ftc-mj identify"
#: Seconds after a labelled event's end also left out (the zero-phase filter's and the arm's settling).
EVENT_SETTLING = 0.5


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[1])
    parser.add_argument("logs", type=Path, nargs="+", metavar="LOG",
                        help="scenario files with a log section: the logs to fit on")
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--only", choices=["friction"], help="friction only: the model's rigid body kept")
    mode.add_argument("--all", action="store_true", help="base inertial parameters, armature and friction")
    parser.add_argument("--out", type=Path, required=True, metavar="FILE.yaml", help="the identified parameters")
    parser.add_argument("--robot", type=Path, metavar="ROBOT",
                        help="the robot: a scenario or a robot file (MJCF, URDF); default: the first LOG's")
    parser.add_argument("--validate", type=Path, nargs="+", default=[], metavar="LOG",
                        help="scenario files with a log section not used for the fit: residual RMS per joint")
    parser.add_argument("--base", type=Path, metavar="SCENARIO",
                        help="write a runnable scenario: base: SCENARIO with the identified parameters")
    parser.add_argument("--cutoff", type=float, default=5.0, metavar="HZ",
                        help="cutoff of the zero-phase low-pass filter [Hz] (default 5)")
    parser.add_argument("--velocity-scale", type=float, default=0.02, metavar="EPS",
                        help="epsilon of the friction's smooth sign tanh(qd / epsilon) [rad/s] (default 0.02)")
    return parser


@exit_status()
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    print("\n".join(identify(args)))
    return 0


def _model(args: argparse.Namespace):
    """The robot's model, its file, joint names and section (``--robot``, else the first log's scenario), and
    the files it was read from."""
    from ftc_mj.config.errors import InputError
    from ftc_mj.logs.trajectory import joint_names
    from ftc_mj.robot.model import RobotSpec, load_robot
    from ftc_mj.scenario.loading import load_scenario

    source = args.robot or args.logs[0]
    if source.suffix in (".yaml", ".yml"):
        scenario = load_scenario(source)
        return (scenario.model, scenario.model_path, joint_names(scenario.model), scenario.spec.robot,
                list(scenario.inputs))
    if not source.is_file():
        raise InputError(str(source), "--robot", "no such file")
    path, model = load_robot(Path.cwd() / "identify", RobotSpec(model=str(source)), str(source))
    return model, path, joint_names(model), RobotSpec(model=str(source)), [source]


def _motions(paths: Sequence[Path], joints: list[str], cutoff: float, read: list[Path]):
    """Each log's filtered motion, its joints checked against the robot's; the files each scenario read
    (bases, model, log) appended to ``read``."""
    import numpy as np

    from ftc_mj.config.errors import InputError
    from ftc_mj.logs.trajectory import joint_names
    from ftc_mj.robot.identify import filtered_motion
    from ftc_mj.scenario.loading import load_scenario

    motions = []
    for path in paths:
        scenario = load_scenario(path)
        read += scenario.inputs
        if scenario.log is None:
            raise InputError(str(path), "log", "identify needs a scenario with a log section")
        logged = joint_names(scenario.model)
        if logged != joints:
            raise InputError(str(path), "robot", f"the log's joints ({', '.join(logged)}) do not match the robot's "
                             f"({', '.join(joints)})")
        log = scenario.log
        keep = None
        if log.events:  # an external torque acts in them: left out, with the filter's settling after each
            keep = np.ones(len(log.times), dtype=bool)
            for event in log.events:
                keep &= ~((log.times >= event.start) & (log.times <= event.end + EVENT_SETTLING))
        motions.append(filtered_motion(str(path), log.times, log.position, log.velocity, log.torque, cutoff, keep))
    return motions


def identify(args: argparse.Namespace) -> list[str]:
    """Fit, validate and write; the report's lines. Raises InputError before writing anything."""
    from ftc_mj.robot.identify import fit_all, fit_friction, residual_rms

    outputs = Outputs(str(args.logs[0]))
    outputs.add("--out", args.out)
    if args.all:
        outputs.add("--out", args.out.with_suffix(".xml"))
    given = [*args.logs, *args.validate, *(p for p in (args.robot, args.base) if p is not None)]
    outputs.check(given)  # before loading: what was named on the command line, whatever it inherits
    model, model_path, joints, robot, read = _model(args)
    motions = _motions(args.logs, joints, args.cutoff, read)
    validation = _motions(args.validate, joints, args.cutoff, read)
    outputs.check([*given, *read])  # before the fit: their bases, models, meshes and logs too
    fit = fit_all if args.all else fit_friction
    identified = fit(model, motions, joints, args.velocity_scale)
    lines = identified.excitation.lines(joints)
    lines.append(f"identified ({identified.mode}) on {', '.join(str(p) for p in args.logs)}:")
    for j, name in enumerate(joints):
        f = identified.friction
        text = f"  {name}: viscous {f.viscous[j]:.4g} N m s/rad, coulomb {f.coulomb[j]:.4g} N m, offset {f.offset[j]:+.4g} N m"
        if identified.armature is not None:
            text += f", armature {identified.armature[j]:.4g} kg m^2"
        lines.append(text)
    lines.append("torque residual RMS per joint [N m], fit: " + " / ".join(f"{x:.3g}" for x in identified.fit_rms))
    for motion in validation:
        rms = residual_rms(model, identified, motion)
        lines.append(f"torque residual RMS per joint [N m], validation on {motion.name}: "
                     + " / ".join(f"{x:.3g}" for x in rms))
    xml = None
    if identified.mode == "all":
        xml = _identified_mjcf(model_path, model, identified, robot)
    text = _fragment(args, identified, joints, xml, lines)
    if xml is not None:
        outputs.write("--out", args.out.with_suffix(".xml"), xml[1].encode("utf-8"))
    outputs.write("--out", args.out, text.encode("utf-8"))
    lines.append(f"written: {args.out}" + ("" if xml is None else f" and {args.out.with_suffix('.xml')}"))
    return lines


def _identified_mjcf(model_path: Path, model, identified, robot) -> tuple[str, str]:
    """The robot's MJCF with the identified bodies' inertials and the joints' armature (MjSpec, by name): (file
    name, text)."""
    import mujoco
    import numpy as np

    from ftc_mj.config.errors import InputError
    from ftc_mj.robot.regressor import Regressor, body_inertial

    if model_path.suffix.lower() == ".urdf":
        raise InputError(str(model_path), "--all", "writes an MJCF model with the identified bodies: give an MJCF "
                         "robot (a URDF's inertials are not rewritten)")
    spec = mujoco.MjSpec.from_file(str(model_path))
    for k, body in enumerate(Regressor(model).bodies):
        mass, com, inertia = body_inertial(identified.phi[k])
        target = spec.body(model.body(body).name)
        if target is None:
            raise InputError(str(model_path), "--all", f"body {model.body(body).name!r} is not in the model file")
        moments, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))  # principal moments and axes
        if np.linalg.det(axes) < 0:
            axes[:, 0] = -axes[:, 0]
        quaternion = np.zeros(4)
        mujoco.mju_mat2Quat(quaternion, axes.reshape(-1))
        target.explicitinertial = True
        target.mass, target.ipos, target.inertia, target.iquat = mass, com, moments, quaternion
    for dof, armature in enumerate(identified.armature):
        spec.joint(model.joint(int(model.dof_jntid[dof])).name).armature = float(armature)
    spec.compile()
    return model_path.name, spec.to_xml()


def _fragment(args, identified, joints: list[str], xml, lines: list[str]) -> str:
    """FILE.yaml: the identified parameters as a scenario fragment, with the command and the report."""
    import yaml

    f = identified.friction
    friction = {"viscous": [round(float(x), 6) for x in f.viscous],
                "coulomb": [round(float(x), 6) for x in f.coulomb],
                "offset": [round(float(x), 6) for x in f.offset],
                "velocity_scale": f.velocity_scale,
                # the fitted b and c are the joints' whole friction: the model file's own is not added again
                "from_model": {"damping": False, "frictionloss": False}}
    document: dict = {"nominal": {"friction": friction}}
    if args.base is not None:
        import os

        document = {"base": os.path.relpath(args.base.resolve(), args.out.resolve().parent), **document}
    if identified.mode == "all":  # the bodies and the armature in the model file
        document["robot"] = {"model": args.out.with_suffix(".xml").name}
    command = " ".join(["ftc-mj identify", *map(str, args.logs), "--all" if args.all else "--only friction",
                        "--out", str(args.out), *(["--robot", str(args.robot)] if args.robot else []),
                        *(["--base", str(args.base)] if args.base else []),
                        *(["--validate", *map(str, args.validate)] if args.validate else [])])
    header = [f"# Identified by: {command}", f"# Joints: {', '.join(joints)}",
              "# A scenario names this file as its base: (nominal.friction: F = b qd + c tanh(qd / "
              "velocity_scale) + o per joint)."]
    header += [f"# {line}" for line in lines]
    return "\n".join(header) + "\n" + yaml.safe_dump(document, sort_keys=False, default_flow_style=None)


if __name__ == "__main__":
    sys.exit(main())
