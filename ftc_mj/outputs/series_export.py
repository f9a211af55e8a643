"""A run's series as a file for MATLAB, pandas or a spreadsheet: ``ftc-mj run ... --export FILE.mat|.parquet|.csv``.

Every series of every variant and monitor (:class:`~ftc_mj.results.VariantResult`: reference, measured, true
and estimated states, the LUaF and its estimate, commanded and delivered torques, the sliding variable, the
faults, each method's own signals and the diagnosis), at the run's own precision (float64: the recording keeps
float32), each with its unit. The forms, by the file's extension:

* ``.mat`` (MATLAB 5 format, ``scipy.io.savemat``): ``t`` (s, a column), ``joints`` (a cell array of the joint
  names), ``units`` (a struct: series -> unit), ``variant_names`` (the variants' and monitors' names as the
  scenario writes them, in the order of ``variants``) and ``variants``, a struct with one field per variant and
  monitor (its name made a MATLAB identifier: ``proposed``, ``proposed_momentum`` for the monitor
  ``proposed.momentum``), each a struct of ``N x n`` matrices (``N x 1`` for a per-sample series), e.g.
  ``run.variants.proposed.luaf_hat(:, 2)``; ``status`` and ``diverged_at`` (NaN if it did not) per variant.
* ``.parquet``: one row per variant and sample: ``variant``, ``t``, then ``<series>.<joint>`` columns, each
  field's unit in its metadata (``unit``).
* ``.csv``: the same table, the unit in each column's name (``q_true.joint1 [rad]``), numbers with 17
  significant digits (read back, the same doubles).

A monitor shares its host's trajectory (its tracking series are the host's) and has its own estimates.
"""

from __future__ import annotations

import io
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ftc_mj.results import VariantResult

#: The forms, by extension.
FORMATS = (".mat", ".parquet", ".csv")
#: Every series exported, in order: name -> (what it is in the result, the kind of unit). The kind is a joint's
#: position, velocity, acceleration or force (per joint: rad or m, N m or N), or a fixed unit.
SERIES: dict[str, tuple[str, str]] = {
    "q_ref": ("q_ref", "position"),
    "qd_ref": ("qd_ref", "velocity"),
    "qdd_ref": ("qdd_ref", "acceleration"),
    "q_meas": ("q_meas", "position"),
    "qd_meas": ("qd_meas", "velocity"),
    "q_true": ("q_true", "position"),
    "qd_true": ("qd_true", "velocity"),
    "qdd_true": ("qdd_true", "acceleration"),
    "qd_hat": ("qd_hat", "velocity"),
    "luaf_true": ("luaf_true", "acceleration"),
    "luaf_hat": ("luaf_hat", "acceleration"),
    "tau": ("tau", "force"),
    "tau_delivered": ("tau_delivered", "force"),
    "sliding": ("sliding", "the controller's"),
    "fault": ("fault", "each term's own space (rad/s^2 or N m)"),
    "fault_torque": ("fault_torque", "force"),
    "fault_acceleration": ("fault_acceleration", "acceleration"),
    "fault_active": ("fault_active", "1"),
}
#: The diagnosis' series (``diagnosis.<name>``), in its space's unit unless said.
DIAGNOSIS_SERIES: dict[str, str] = {
    "signal": "space", "fault_estimate": "space", "residual": "space", "threshold": "space", "alarm": "1",
    "armed": "1", "injected": "space",
}
_UNITS = {
    "position": ("rad", "m"), "velocity": ("rad/s", "m/s"), "acceleration": ("rad/s^2", "m/s^2"),
    "force": ("N m", "N"),
}


def export_path_problem(path: Path) -> str | None:
    """Why ``path`` names no export form (its extension), or None."""
    if path.suffix.lower() not in FORMATS:
        return f"{str(path)!r}: the extension must be one of {', '.join(FORMATS)}"
    return None


def collect(results: Sequence[VariantResult], slides: Sequence[bool]) -> tuple[list[tuple[str, dict]], dict]:
    """Per variant and monitor (in order), its series by name (float64 arrays, ``(N, n)`` or ``(N,)``); and
    each series' unit (per joint for joint series: ``slides[j]`` a slide joint)."""
    units: dict[str, str | list[str]] = {}
    found: list[tuple[str, dict]] = []
    for one in _every(results):
        series = {}
        for name, (attribute, kind) in SERIES.items():
            values = getattr(one, attribute)
            if values is not None:
                series[name] = np.asarray(values, dtype=np.float64)
                units[name] = _unit(kind, slides)
        for name, values in one.extras.items():
            series[f"extras.{name}"] = np.asarray(values, dtype=np.float64)
            units[f"extras.{name}"] = "the method's"
        if one.diagnosis is not None:
            space = _unit("force" if one.diagnosis.space == "torque" else "acceleration", slides)
            for name, kind in DIAGNOSIS_SERIES.items():
                series[f"diagnosis.{name}"] = np.asarray(getattr(one.diagnosis, name), dtype=np.float64)
                units[f"diagnosis.{name}"] = space if kind == "space" else kind
        found.append((one.name, series))
    return found, units


def _unit(kind: str, slides: Sequence[bool]) -> str | list[str]:
    if kind not in _UNITS:
        return kind
    hinge, slide = _UNITS[kind]
    per_joint = [slide if s else hinge for s in slides]
    return per_joint[0] if len(set(per_joint)) == 1 else per_joint


def export_bytes(path: Path, results: Sequence[VariantResult], joints: Sequence[str], slides: Sequence[bool]) -> bytes:
    """The file's bytes in the form ``path``'s extension names (the module docstring)."""
    suffix = path.suffix.lower()
    if suffix == ".mat":
        return mat_bytes(results, joints, slides)
    table = long_table(results, joints, slides)
    if suffix == ".parquet":
        from ftc_mj.outputs.files import parquet_bytes

        return parquet_bytes(table)
    return csv_bytes(table)


def mat_bytes(results: Sequence[VariantResult], joints: Sequence[str], slides: Sequence[bool]) -> bytes:
    """The ``.mat`` form (the module docstring)."""
    from scipy.io import savemat

    found, units = collect(results, slides)
    variants, names, taken = {}, [], set()
    for name, series in found:
        field = _identifier(name, taken)
        one = next(r for r in _every(results) if r.name == name)
        variants[field] = {
            **{key.replace(".", "_"): (values[:, None] if values.ndim == 1 else values)
               for key, values in series.items()},
            "t": np.asarray(one.t, dtype=np.float64)[:, None],
            "status": one.status,
            "diverged_at": np.nan if one.diverged_at is None else float(one.diverged_at),
        }
        names.append(name)
    document = {
        "t": np.asarray(results[0].t, dtype=np.float64)[:, None],
        "joints": np.array(list(joints), dtype=object),
        "variant_names": np.array(names, dtype=object),
        "units": {key.replace(".", "_"): (np.array(value, dtype=object) if isinstance(value, list) else value)
                  for key, value in units.items()},
        "variants": variants,
    }
    buffer = io.BytesIO()
    savemat(buffer, document, long_field_names=True, do_compression=True, oned_as="column")
    return buffer.getvalue()


def _every(results: Sequence[VariantResult]) -> list[VariantResult]:
    """Every variant and monitor once, in order (a run's results may list its monitors beside their hosts)."""
    found: dict[str, VariantResult] = {}
    for result in results:
        for one in (result, *result.monitors):
            found.setdefault(one.name, one)
    return list(found.values())


def _identifier(name: str, taken: set[str]) -> str:
    """``name`` as a MATLAB identifier (letters, digits, ``_``; a letter first; at most 63 characters),
    unique among ``taken``."""
    field = re.sub(r"[^A-Za-z0-9_]", "_", name)
    if not field or not field[0].isalpha():
        field = f"v_{field}"
    field = field[:63]
    base, k = field, 2
    while field in taken:
        suffix = f"_{k}"
        field, k = base[:63 - len(suffix)] + suffix, k + 1
    taken.add(field)
    return field


def long_table(results: Sequence[VariantResult], joints: Sequence[str], slides: Sequence[bool]):
    """One row per variant (and monitor) and sample: ``variant``, ``t``, ``<series>.<joint>`` (``<series>``
    alone for a per-sample series), each field's unit in its metadata; a series a variant lacks is null."""
    import pyarrow as pa

    found, units = collect(results, slides)
    every = {one.name: one for one in _every(results)}
    column_units: dict[str, str] = {}
    per_variant: list[dict[str, np.ndarray]] = []
    for name, series in found:
        columns = {}
        for key, values in series.items():
            unit = units[key]
            if values.ndim == 1:
                columns[key] = values
                column_units.setdefault(key, unit)
                continue
            for j, joint in enumerate(joints):
                columns[f"{key}.{joint}"] = values[:, j]
                column_units.setdefault(f"{key}.{joint}", unit[j] if isinstance(unit, list) else unit)
        per_variant.append(columns)
    lengths = [len(every[name].t) for name, _ in found]
    fields = [pa.field("variant", pa.string()), pa.field("t", pa.float64(), metadata={"unit": "s"})]
    fields += [pa.field(c, pa.float64(), metadata={"unit": unit}) for c, unit in column_units.items()]
    arrays = [pa.array([name for (name, _), length in zip(found, lengths) for _ in range(length)], pa.string()),
              pa.array(np.concatenate([np.asarray(every[name].t, np.float64) for name, _ in found]))]
    for column in column_units:
        parts = [columns.get(column) for columns in per_variant]
        values = np.concatenate([p if p is not None else np.full(n, np.nan) for p, n in zip(parts, lengths)])
        missing = np.concatenate([np.full(n, p is None) for p, n in zip(parts, lengths)])
        arrays.append(pa.array(values, pa.float64(), mask=missing))
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields))


def csv_bytes(table) -> bytes:
    """The table as CSV: a header of names with their units, numbers with 17 significant digits (NaN as
    ``NaN``, a series a variant lacks empty)."""
    names = ["variant", "t [s]"] + [f"{field.name} [{field.metadata[b'unit'].decode()}]"
                                    for field in list(table.schema)[2:]]
    columns = [table.column(k) for k in range(1, table.num_columns)]
    numbers = np.column_stack([c.to_numpy(zero_copy_only=False).astype(np.float64) for c in columns])
    missing = np.column_stack([c.is_null().to_numpy(zero_copy_only=False) for c in columns])
    lines = [",".join(_csv_text(name) for name in names)]
    for row, label in enumerate(table.column("variant").to_pylist()):
        cells = ("" if gone else "NaN" if np.isnan(v) else f"{v:.17g}" for v, gone in zip(numbers[row], missing[row]))
        lines.append(",".join([_csv_text(label), *cells]))
    return ("\n".join(lines) + "\n").encode("utf-8")


def _csv_text(text: str) -> str:
    return f'"{text.replace(chr(34), chr(34) * 2)}"' if any(c in text for c in ',"\n') else text
