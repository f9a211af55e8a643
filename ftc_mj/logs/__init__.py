"""Recorded robot logs as the plant of a run: the scenario's ``log`` section (:mod:`~ftc_mj.logs.schema`), the
readers of CSV, rosbag2 and MCAP files (:mod:`~ftc_mj.logs.readers`), the compiled trajectory on the observers'
grid (:mod:`~ftc_mj.logs.trajectory`), the controller that is the log's torque (:mod:`~ftc_mj.logs.controller`)
and the export of a simulated run as a log (:mod:`~ftc_mj.logs.export`).

Layering: above ``config``, ``results``, ``robot`` and ``methods`` (the log's controller is a
:class:`~ftc_mj.methods.controllers.base.Controller`), below ``spec`` (which holds the ``log`` section) and
``engine`` (whose :class:`~ftc_mj.engine.plant.LogPlant` plays the trajectory back)."""
