"""Check a robot before its first run: ``ftc-mj robot check SCENARIO_OR_ROBOT [options]``.

Prints per joint its type, range, torque limit, armature, damping and friction loss of the plant, the
nominal model's M(q0) diagonal (and M's smallest eigenvalue), gravity at the initial posture, the peak torque
the reference needs (nominal inverse dynamics), then the warnings of :mod:`ftc_mj.robot.check` (heuristics:
damping against the control period, the observer's rate bound, a wrist without armature, torque limits, no
armature at all, suspicious units). A scenario gives the posture, reference, control period and gains; a
robot file (MJCF, URDF or ``package://...``) alone is checked at its reference posture.

Exit status: 0 (warnings included), 2 on bad input (one line naming the file, the field and the problem).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ftc_mj.cli.command import exit_status
from ftc_mj.cli.parser import ArgumentParser

if TYPE_CHECKING:
    from ftc_mj.robot.check import RobotCheck
    from ftc_mj.scenario.definition import Scenario

PROG = "ftc-mj robot"
#: At most this many reference samples go through the inverse dynamics.
_REFERENCE_SAMPLES = 2000


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=prog, description=__doc__.split("\n\n")[1])
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION", parser_class=ArgumentParser)
    check = actions.add_parser("check", help="per-joint numbers and warnings before a first run")
    check.add_argument("target", metavar="SCENARIO_OR_ROBOT",
                       help="scenario YAML, or a robot model file (MJCF, .urdf, package://...)")
    check.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                       help="override a scenario field, e.g. robot.armature=0.1")
    return parser


@exit_status()
def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    args = build_parser(prog).parse_args(argv)
    print(format_report(args.target, _check(args.target, args.overrides)))
    return 0


def _check(target: str, overrides: Sequence[str]):
    from ftc_mj.config.errors import InputError
    from ftc_mj.robot.check import check_robot

    if target.endswith((".yaml", ".yml")):
        from ftc_mj.scenario.loading import load_scenario

        return scenario_check(load_scenario(Path(target), overrides=list(overrides)))
    if overrides:
        raise InputError(target, "--set", "is for scenarios; a robot file is checked as it is")
    from ftc_mj.robot.model import RobotSpec, load_robot

    _, model = load_robot(Path.cwd() / "robot-check", RobotSpec(model=target), target)
    return check_robot(model)


def scenario_check(scenario: Scenario) -> RobotCheck:
    """:func:`~ftc_mj.robot.check.check_robot` of a loaded scenario: its model, initial posture, reference
    (at most :data:`_REFERENCE_SAMPLES` samples), control period, observers' rate bounds and nominal mass
    scale."""
    import numpy as np

    from ftc_mj.robot.check import check_robot

    times = scenario.times
    times = times[::max(1, len(times) // _REFERENCE_SAMPLES)]
    parameters = None
    if scenario.reference.parameters:
        values = scenario.spec.parameters or {}
        parameters = np.array([[values[name] for name in scenario.reference.parameters]], dtype=float)
    reference = scenario.reference.evaluate(times, parameters)
    if parameters is not None:
        reference = tuple(x[:, 0, :] for x in reference)
    bounds = [(v.name, np.broadcast_to(np.asarray(v.observer_config.D, dtype=float), (scenario.n_joints,)))
              for v in scenario.variants if getattr(v.observer_config, "D", None) is not None]
    return check_robot(scenario.model, q0=scenario.q0, reference=reference, reference_times=times,
                       control_dt=scenario.spec.control_dt, observer_rate_bounds=bounds,
                       mass_scale=scenario.spec.nominal.mass_scale, friction=scenario.spec.nominal.friction)


def short_warning(warning: str) -> str:
    """A check warning in short, as ``run`` prints it at load time: without its parentheses and cut after
    its subject and first statement (``joint 'x': ...``, up to a ``:`` or ``;``)."""
    import re

    text = re.sub(r" \([^()]*\)", "", warning)
    return ": ".join(text.split(": ")[:2]).split("; ")[0]


def format_report(target: str, report) -> str:
    """The per-joint table, M's smallest eigenvalue, then one line per warning."""
    header = ("joint", "type", "range", "limit", "armature", "damping", "friction", "M_jj(q0)", "G(q0)",
              "peak tau_ref", "d dt/M", "armature needed")
    rows = [header]
    for c in report.joints:
        rows.append((
            c.name, c.kind, "free" if c.range is None else f"[{c.range[0]:.3g}, {c.range[1]:.3g}]",
            "none" if c.torque_limit is None else f"{c.torque_limit:.4g}", f"{c.armature:.3g}", f"{c.damping:.3g}",
            f"{c.frictionloss:.3g}", f"{c.mass_diagonal:.3g}", f"{c.gravity:.3g}",
            "-" if c.peak_reference_torque is None else f"{c.peak_reference_torque:.3g}",
            "-" if report.control_dt is None else f"{c.sampling_ratio:.2g}",
            f"{c.armature_needed:.3g}" if c.armature_needed else "-"))
    widths = [max(len(row[k]) for row in rows) for k in range(len(header))]
    lines = [f"{target}: {len(report.joints)} joints (units: rad, N m, kg m^2, N m s/rad)"]
    lines += ["  ".join(cell.ljust(w) for cell, w in zip(row, widths)).rstrip() for row in rows]
    lines.append(f"smallest eigenvalue of M(q0): {report.min_eigenvalue:.3g} kg m^2")
    lines += [f"nominal model: {line}" if not line.startswith("  ") else line for line in report.nominal_terms]
    lines += [f"warning: {w}" for w in report.warnings] or ["no warnings"]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
