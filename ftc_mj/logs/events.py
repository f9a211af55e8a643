"""Labelled windows of a log (``log.events``): when something happened to the arm (a push, a collision, a
tool change), on which joints, read off the data or known from the experiment, and the diagnosis scored
against them.

A log has no ground truth: no injected fault, no true LUaF. What the diagnosis can still be scored on is
its alarms against what the user knows happened. Each event is ``{start, end, joints, label}`` (times on the
run's grid, from the log's first sample [s]; joints by 1-based number or name). Per joint (:func:`event_metrics`):

* ``events_detected``: the share of the events that name the joint during which the joint's alarm is on at
  an armed sample (NaN for a joint no event names);
* ``event_delay``: over those detected, the mean time from the event's start to its first alarm on the joint
  [s] (an alarm still on at the start counts from the start: 0);
* ``alarms_outside_events``: alarms raised (rising edges, armed) outside every event's window: the false
  alarms of a log;
* ``alarms_on_other_joints``: alarms raised inside an event's window on a joint it does not name (a push is
  felt by several joints: where the labels name only those pushed, this is isolation).

The events are data, not truth: where they were read off the logged torques, the diagnosis is scored
against the same currents its residuals come from, and a push too weak to move the torques beyond their
noise is in no window.
"""

from __future__ import annotations

from typing import Annotated

import numpy as np
from pydantic import Field, StrictInt, StrictStr, model_validator

from ftc_mj.config.errors import InputError
from ftc_mj.config.types import NonNegativeFloat, PositiveFloat, Strict
from ftc_mj.results import Diagnosis

#: The metrics of :func:`event_metrics`, in table order, and their units.
EVENT_METRICS: dict[str, str] = {
    "events_detected": "share",
    "event_delay": "s",
    "alarms_outside_events": "count",
    "alarms_on_other_joints": "count",
}


class EventSpec(Strict):
    """One labelled window of a log."""

    #: Start and end of the window [s], on the run's time (0 at the log's first sample).
    start: NonNegativeFloat
    end: PositiveFloat
    #: The joints it acts on, by 1-based number or name.
    joints: Annotated[list[Annotated[StrictInt, Field(ge=1)] | StrictStr], Field(min_length=1)]
    #: What happened, e.g. ``push on the shoulder lift``.
    label: StrictStr = ""

    @model_validator(mode="after")
    def _ordered(self) -> "EventSpec":
        if self.end <= self.start:
            raise ValueError(f"end {self.end} must be after start {self.start}")
        return self


class Event:
    """An event compiled for a robot: its window and joint indices (0-based, the robot's order)."""

    def __init__(self, start: float, end: float, joints: list[int], label: str):
        self.start, self.end, self.joints, self.label = float(start), float(end), list(joints), label


def compile_events(events: list[EventSpec], joint_names: list[str], file: str) -> list[Event]:
    """The events with their joints as indices; an unknown joint is an :class:`InputError` naming it."""
    compiled = []
    for e, event in enumerate(events):
        indices = []
        for k, joint in enumerate(event.joints):
            if isinstance(joint, int):
                if joint > len(joint_names):
                    raise InputError(file, f"log.events.{e}.joints.{k}", f"joint {joint}: the robot has "
                                     f"{len(joint_names)} joints")
                indices.append(joint - 1)
            elif joint in joint_names:
                indices.append(joint_names.index(joint))
            else:
                raise InputError(file, f"log.events.{e}.joints.{k}", f"{joint!r} is not a joint of the robot "
                                 f"({', '.join(joint_names)})")
        compiled.append(Event(event.start, event.end, indices, event.label))
    return compiled


def event_metrics(diagnosis: Diagnosis | None, events: list[Event], n: int) -> dict[str, np.ndarray]:
    """:data:`EVENT_METRICS` per joint (module docstring); NaN everywhere without a diagnosis or events."""
    out = {name: np.full(n, np.nan) for name in EVENT_METRICS}
    if diagnosis is None or not events or diagnosis.t.size == 0:
        return out
    t, alarm, armed = diagnosis.t, diagnosis.alarm, diagnosis.armed
    raised = diagnosis.raised & armed[:, None]
    inside = np.zeros(len(t), dtype=bool)
    named_inside = np.zeros(alarm.shape, dtype=bool)  # inside a window of an event that names the joint
    detected, named, delays = np.zeros(n), np.zeros(n), [[] for _ in range(n)]
    for event in events:
        window = (t >= event.start) & (t <= event.end)
        inside |= window
        for j in event.joints:
            named[j] += 1
            named_inside[window, j] = True
            on = np.flatnonzero(window & armed & alarm[:, j])
            if on.size:
                detected[j] += 1
                delays[j].append(max(0.0, float(t[on[0]] - event.start)))
    out["alarms_outside_events"] = raised[~inside].sum(axis=0).astype(float)
    out["alarms_on_other_joints"] = (raised & inside[:, None] & ~named_inside).sum(axis=0).astype(float)
    for j in range(n):
        if named[j]:
            out["events_detected"][j] = detected[j] / named[j]
        if delays[j]:
            out["event_delay"][j] = float(np.mean(delays[j]))
    return out


#: The diagnosis metrics a log's events replace: counted against no fault, they count the events themselves.
REPLACED = ("false_alarms", "false_alarm_rate")
#: The controller's metrics, of the logged torque on a log: the same for every variant, none of its doing.
LOGGED = ("chattering", "saturation_time")


def log_metrics(events: list[Event], results: list, metrics: dict[str, dict], shown: list[str]) -> list[str]:
    """For a replayed log: each result's :func:`event_metrics` added to its ``metrics`` (where the log has
    events), and the table's metrics: ``shown`` without those no result defines (those that need ground truth)
    and the logged torque's (:data:`LOGGED`), with events without :data:`REPLACED` either, then the event
    metrics."""
    if events:
        for result in results:
            n = len(next(iter(metrics[result.name].values())))
            metrics[result.name].update(event_metrics(result.diagnosis, events, n))
    defined = [name for name in shown if not (events and name in REPLACED) and name not in LOGGED
               and any(np.isfinite(metrics[r.name][name]).any() for r in results)]
    return defined + [name for name in EVENT_METRICS if events and name not in defined
                      and any(np.isfinite(metrics[r.name][name]).any() for r in results)]
