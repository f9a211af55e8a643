"""Monitoring beside a real robot: a scenario's observer and causal diagnosis on a stream of samples
(:class:`~ftc_mj.online.monitor.Monitor`), the rule for sample times (:mod:`ftc_mj.online.grid`), the map
from a source's joints and units to the robot's (:mod:`ftc_mj.online.inputs`), and the ROS 2 node
(:mod:`ftc_mj.online.ros`, with the extra ``ftc_mj[ros]``)."""

from ftc_mj.online.grid import SampleError
from ftc_mj.online.inputs import InputMap
from ftc_mj.online.monitor import Monitor, Period

__all__ = ["InputMap", "Monitor", "Period", "SampleError"]
