"""Identification (ftc_mj/robot/regressor.py, ftc_mj/robot/identify.py, ftc-mj identify): the regressor is the
model's inverse dynamics, a fit recovers the friction (and, on exciting motion, the base parameters) that made
a synthetic log, and bad input is one line, exit 2, nothing written."""

from __future__ import annotations

import copy
from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from ftc_mj.cli.identify import main
from ftc_mj.robot.friction import JointFriction
from ftc_mj.robot.identify import filtered_motion, fit_all, fit_friction, residual_rms
from ftc_mj.robot.regressor import Regressor, body_inertial, physical_problem, standard_parameters
from ftc_mj.scenario.loading import load_scenario

ROOT = Path(__file__).resolve().parents[2]
UR10E = ROOT / "models" / "ur10e" / "ur10e.xml"
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint"]
#: The friction a synthetic log is made with: the UR10e's identified one.
TRUE_FRICTION = JointFriction([21.3, 20.2, 10.4, 3.6, 2.5, 3.0], [12.5, 13.3, 5.0, 2.0, 2.7, 2.3],
                              [0.2, -0.75, 0.2, 0.05, -0.01, 0.04])
DT = 0.01


def _rigid(model: mujoco.MjModel) -> mujoco.MjModel:
    rigid = copy.deepcopy(model)
    rigid.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_DAMPER | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    return rigid


@pytest.fixture(scope="module")
def ur10e() -> mujoco.MjModel:
    path = ROOT / "scenarios" / "real" / "ur10e_free_motion.yaml"
    return load_scenario(path).model


def test_the_regressor_is_the_models_inverse_dynamics(ur10e):
    """Y(q, qd, qdd) phi + armature qdd = mj_inverse at random states, to rounding (measured 4e-14 N m), for a
    tree (the UR10e) and the PUMA560 with its welded wrist; the parameters back from phi are the model's."""
    puma = mujoco.MjModel.from_xml_path(str(ROOT / "models" / "puma560.xml"))
    rng = np.random.default_rng(0)
    for model in (ur10e, puma):
        regressor = Regressor(model)
        q, qd, qdd = (rng.uniform(-3, 3, (6, model.nv)), rng.normal(size=(6, model.nv)),
                      rng.normal(size=(6, model.nv)))
        torque = regressor(q, qd, qdd) @ regressor.parameters() + model.dof_armature * qdd
        rigid, data = _rigid(model), mujoco.MjData(model)
        for s in range(len(q)):
            data.qpos[:], data.qvel[:], data.qacc[:] = q[s], qd[s], qdd[s]
            mujoco.mj_inverse(rigid, data)
            np.testing.assert_allclose(torque[s], data.qfrc_inverse, rtol=0, atol=1e-9)
        for k, body in enumerate(regressor.bodies):
            mass, com, _ = body_inertial(standard_parameters(model, regressor.bodies)[k])
            assert mass == pytest.approx(model.body_mass[body])
            np.testing.assert_allclose(com, model.body_ipos[body], atol=1e-12)


def test_physical_consistency_is_checked():
    phi = np.array([2.0, 0.2, 0.0, 0.0, 0.05, 0.0, 0.0, 0.05, 0.0, 0.05])
    assert physical_problem(phi) is None
    assert "mass" in physical_problem(np.r_[-1.0, phi[1:]])
    assert "not positive definite" in physical_problem(np.r_[phi[:4], -0.05, phi[5:]])


def synthetic_log(model: mujoco.MjModel, seconds: float, amplitude: float, friction: JointFriction | None,
                  frequency: float = 0.35) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """times, q, qd, tau of a smooth multi-sine motion of every joint, tau the model's inverse dynamics plus
    ``friction``."""
    times = np.arange(0.0, seconds, DT)
    n = model.nv
    phases = np.arange(n)[:, None] * 0.7
    harmonics = np.array([1.0, 2.3, 3.1])[:, None, None]
    weights = np.array([1.0, 0.4, 0.25])[:, None, None]
    angle = 2 * np.pi * frequency * harmonics * times[None, None, :] + phases[None]
    q = (amplitude * weights * np.sin(angle)).sum(axis=0).T + np.array([0.0, -1.3, 1.3, -1.5, -1.5, 0.0])[:n]
    qd = (amplitude * weights * 2 * np.pi * frequency * harmonics * np.cos(angle)).sum(axis=0).T
    qdd = (-amplitude * weights * (2 * np.pi * frequency * harmonics) ** 2 * np.sin(angle)).sum(axis=0).T
    rigid, data = _rigid(model), mujoco.MjData(model)
    tau = np.zeros_like(q)
    for s in range(len(times)):
        data.qpos[:], data.qvel[:], data.qacc[:] = q[s], qd[s], qdd[s]
        mujoco.mj_inverse(rigid, data)
        tau[s] = data.qfrc_inverse
    if friction is not None:
        tau += friction.torque(qd)
    return times, q, qd, tau


def test_friction_only_recovers_the_friction_the_log_was_made_with(ur10e):
    """On a synthetic log of the model's own rigid body plus the UR10e's friction, the friction-only fit gives
    it back (within 2 %: the filter's edges and the central differences), with a torque residual below
    0.5 N m; a fit whose sign of the torque is flipped is far off."""
    times, q, qd, tau = synthetic_log(ur10e, 12.0, 0.4, TRUE_FRICTION)
    motion = filtered_motion("synthetic", times, q, qd, tau)
    fitted = fit_friction(ur10e, [motion], JOINTS)
    np.testing.assert_allclose(fitted.friction.viscous, TRUE_FRICTION.viscous, rtol=0.02)
    np.testing.assert_allclose(fitted.friction.coulomb, TRUE_FRICTION.coulomb, rtol=0.02)
    np.testing.assert_allclose(fitted.friction.offset, TRUE_FRICTION.offset, atol=0.1)
    assert np.all(fitted.fit_rms < 0.5), fitted.fit_rms
    # Validated on another motion of the same arm: the same level.
    other = filtered_motion("other", *synthetic_log(ur10e, 8.0, 0.3, TRUE_FRICTION, frequency=0.5))
    assert np.all(residual_rms(ur10e, fitted, other) < 0.5)


def perturbed(model: mujoco.MjModel) -> mujoco.MjModel:
    """The arm with a forearm 30 % heavier (mass and inertia) and the shoulder lift's armature 0.5 kg m^2: what
    an all-parameter fit starting from ``model`` has to find."""
    other = copy.deepcopy(model)
    forearm = mujoco.mj_name2id(other, mujoco.mjtObj.mjOBJ_BODY, "forearm_link")
    other.body_mass[forearm] *= 1.3
    other.body_inertia[forearm] *= 1.3
    other.dof_armature[1] = 0.5
    return other


@pytest.mark.slow  # all-parameter fits
def test_all_recovers_the_torque_and_refuses_data_that_cannot_support_it(ur10e):
    """Every parameter on an exciting synthetic log (every joint over 1 rad, both directions) of a perturbed
    arm, from the nominal model: on another motion the fit's torque matches the arm's to 0.5 N m (measured
    0.06 / 0.13 / 0.06; the nominal model with the right friction misses it by 3.4 / 17 / 3.7), every body is
    physical (the linear fit asked for an upper arm that is not: the log-Cholesky fit), the friction comes
    back; the same fit is refused on a slow, narrow motion, with the reasons. The shoulder lift's armature is
    not checked: it and the upper arm's moment about that axis form one base parameter."""
    arm = perturbed(ur10e)
    motion = filtered_motion("exciting", *synthetic_log(arm, 20.0, 0.7, TRUE_FRICTION))
    fitted = fit_all(ur10e, [motion], JOINTS)
    assert fitted.excitation.base_parameters < 10 * len(Regressor(ur10e).bodies) + 4 * 6  # QR found the base set
    other = filtered_motion("other", *synthetic_log(arm, 8.0, 0.5, TRUE_FRICTION, frequency=0.5))
    rms = residual_rms(ur10e, fitted, other)
    assert np.all(rms < 0.5), rms
    nominal = residual_rms(ur10e, fit_friction(ur10e, [motion], JOINTS), other)
    assert nominal[1] > 4 * rms[1], (nominal, rms)
    np.testing.assert_allclose(fitted.friction.viscous, TRUE_FRICTION.viscous, rtol=0.05, atol=0.2)
    narrow = filtered_motion("narrow", *synthetic_log(ur10e, 6.0, 0.15, TRUE_FRICTION))
    from ftc_mj.config.errors import InputError

    with pytest.raises(InputError, match="cannot support identifying every parameter"):
        fit_all(ur10e, [narrow], JOINTS)


def _log_scenario(tmp_path: Path, name: str, times, q, qd, tau) -> Path:
    csv = tmp_path / f"{name}.csv"
    np.savetxt(csv, np.column_stack([times, q, qd, tau]), delimiter=",")
    scenario = {"name": name, "robot": {"model": str(UR10E), "joints": JOINTS},
                "log": {"file": csv.name, "format": "csv", "steps": {"resample": DT},
                        "columns": {"time": 0, "position": list(range(1, 7)), "velocity": list(range(7, 13)),
                                    "torque": list(range(13, 19))}},
                "variants": {"momentum": {"observer": {"type": "momentum", "gains": {"K": 50.0}}}}}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(scenario), encoding="utf-8")
    return path


def test_the_command_writes_a_base_file_that_replays(tmp_path, ur10e, capsys):
    fit = _log_scenario(tmp_path, "fit", *synthetic_log(ur10e, 10.0, 0.4, TRUE_FRICTION))
    check = _log_scenario(tmp_path, "check", *synthetic_log(ur10e, 6.0, 0.3, TRUE_FRICTION, frequency=0.5))
    out = tmp_path / "identified.yaml"
    assert main([str(fit), "--only", "friction", "--out", str(out), "--validate", str(check),
                 "--base", str(check)]) == 0
    report = capsys.readouterr().out
    assert "excitation: 920 samples" in report  # 1000 less 0.4 s at each end and "validation on" in report
    written = yaml.safe_load(out.read_text())
    np.testing.assert_allclose(written["nominal"]["friction"]["viscous"], TRUE_FRICTION.viscous, rtol=0.02)
    scenario = load_scenario(out)  # runnable: the check log with the identified friction
    assert scenario.spec.nominal.friction.coulomb[1] == pytest.approx(13.3, rel=0.02)


@pytest.mark.slow  # fits (the --all cases)
@pytest.mark.parametrize("case, problem", [
    ("short", "fewer than the 200 identification needs"),
    ("slow", "too slow to identify from"),
    ("other robot", "do not match the robot's"),
    ("flipped --all", "not physical"),
    ("narrow --all", "cannot support"),
])
def test_bad_input_is_one_line_exit_2_nothing_written(tmp_path, ur10e, capsys, case, problem):
    arguments = ["--only", "friction"]
    if case == "short":
        log = _log_scenario(tmp_path, "log", *synthetic_log(ur10e, 1.5, 0.4, TRUE_FRICTION))
    elif case == "slow":
        log = _log_scenario(tmp_path, "log", *synthetic_log(ur10e, 6.0, 0.01, TRUE_FRICTION))
    elif case == "other robot":
        log = _log_scenario(tmp_path, "log", *synthetic_log(ur10e, 6.0, 0.4, TRUE_FRICTION))
        arguments += ["--robot", str(ROOT / "models" / "puma560.xml")]
    elif case == "flipped --all":
        times, q, qd, tau = synthetic_log(ur10e, 20.0, 0.7, TRUE_FRICTION)
        log, arguments = _log_scenario(tmp_path, "log", times, q, qd, -tau), ["--all"]
    else:
        log, arguments = _log_scenario(tmp_path, "log", *synthetic_log(ur10e, 6.0, 0.15, TRUE_FRICTION)), ["--all"]
    out = tmp_path / "out.yaml"
    assert main([str(log), *arguments, "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and problem in error and "Traceback" not in error, error
    assert not out.exists() and not out.with_suffix(".xml").exists()


@pytest.mark.slow  # an all-parameter fit
def test_all_writes_a_model_file_the_scenario_loads(tmp_path, ur10e):
    """--all on an exciting log of the perturbed arm: FILE.yaml names FILE.xml, the robot with the identified
    bodies and armature, and the scenario it makes (--base) loads it."""
    log = _log_scenario(tmp_path, "fit", *synthetic_log(perturbed(ur10e), 20.0, 0.7, TRUE_FRICTION))
    out = tmp_path / "all.yaml"
    assert main([str(log), "--all", "--out", str(out), "--base", str(log)]) == 0
    assert yaml.safe_load(out.read_text())["robot"] == {"model": "all.xml"}
    identified = load_scenario(out).model
    assert np.all(identified.body_mass[Regressor(ur10e).bodies] > 0) and np.all(identified.dof_armature >= 0)
    assert not np.allclose(identified.body_inertia, ur10e.body_inertia)  # the file holds the fitted bodies


@pytest.mark.parametrize("target", ["log scenario", "validation log", "log data"])
def test_out_never_overwrites_an_input(tmp_path, ur10e, capsys, target):
    """``--out`` naming a file the command reads (a log's scenario, a validation log, the data a scenario
    reads) is refused before any fit, in one line, and the file is left as it was."""
    log = _log_scenario(tmp_path, "log", *synthetic_log(ur10e, 6.0, 0.4, TRUE_FRICTION))
    check = _log_scenario(tmp_path, "check", *synthetic_log(ur10e, 6.0, 0.4, TRUE_FRICTION))
    read = [Path(p) for p in load_scenario(log).inputs if Path(p).suffix not in (".yaml", ".yml", ".xml")]
    out = {"log scenario": log, "validation log": check, "log data": read[0] if read else log}[target]
    before = out.read_bytes()
    assert main([str(log), "--only", "friction", "--validate", str(check), "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "--out" in error and "is an input" in error, error
    assert out.read_bytes() == before
