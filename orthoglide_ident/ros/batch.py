"""High-rate topics taken in batches: what rclpy's executor costs per message, paid per wake-up.

rclpy's Python executor rebuilds its wait set and runs a callback for every message: ~0.1 ms each
here, so one 1 kHz topic costs a node ~10 % of a core, and the recorder's three ~30 %. On a 2-core
robot computer next to a 1 kHz controller that is the difference between keeping up and losing
ticks. ``BatchTaker`` waits on a few subscriptions of its own on one thread and, at each wake-up
(at most every ``period_s``), takes every pending message of every topic and hands them over in
one call per topic: the same 3 kHz cost ~4 % of a core instead of ~30 % (bench/ros_intake.py).

The subscriptions live on a small private node (``_<node>_rx``) that no executor spins; it
subscribes to the topic names as the owning node resolves them, so remapping and namespaces of the
owner apply. Its name starts with an underscore, ROS 2's mark of a hidden node: ``ros2 node list``
shows the four nodes a user started, ``ros2 node list -a`` the helpers too (and ``ros2 topic info
-v`` names them as the subscribers of the 1 kHz topics). Messages are handed over serialized
(CDR bytes) with their receive and publish times.

``drain()`` hands over, before it returns, every message the subscriptions held when it was
called (the recorder's stop writes what had arrived). A callback that raises loses its batch, is
logged (ros.guard) and the thread goes on; if the thread itself cannot go on, the owner is
marked so (``cannot_go_on``) and the spin helper ends the node with exit code 1 rather than leave
it up and deaf to its topics.
"""
from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import rclpy
from rclpy.exceptions import InvalidHandle
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile

from orthoglide_ident.ros.guard import FailureLog, cannot_go_on

Batch = list[tuple[bytes, int, int]]  # (serialized message, receive time ns, publish time ns)


@dataclass
class BatchTopic:
    msg_type: Any
    topic: str  # as the owning node names it (relative names resolve in its namespace)
    qos: QoSProfile
    on_batch: Callable[[Batch], None]


def real_time_thread(priority: int) -> str | None:
    """SCHED_FIFO at ``priority`` for the calling thread (Linux: pid 0 is the calling thread;
    threads it starts afterwards inherit it); the reason when the system refuses, else None."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(min(priority, 99)))
    except (OSError, AttributeError) as e:
        return str(e)
    return None


class BatchTaker:
    """Take the messages of ``topics`` in batches on a thread of its own; ``close()`` to stop."""

    def __init__(self, owner: Node, topics: list[BatchTopic], period_s: float = 0.005,
                 rt_priority: int = 0, on_wake: Callable[[], None] | None = None,
                 wake_s: float = 0.1):
        self.owner = owner
        self.period_s = period_s
        # called after every wake-up, messages or not: at least every wake_s while none come
        # (the ctc sends ready feed-forward when a tick nears, whether or not setpoints arrive)
        self.on_wake, self.wake_ns = on_wake, int(wake_s * 1e9)
        self.rt_priority = rt_priority  # > 0: the thread runs SCHED_FIFO at this priority
        self.node = rclpy.create_node(f"_{owner.get_name()}_rx", namespace=owner.get_namespace(),
                                      context=owner.context, use_global_arguments=False,
                                      start_parameter_services=False)
        self.subs: list[tuple[Any, Callable[[Batch], None]]] = []
        self._topics: list[str] = []  # resolved name of each subscription in self.subs
        self._new: list[BatchTopic] = list(topics)  # subscribed by the thread (it owns the node)
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._drains: list[threading.Event] = []  # drain() calls waiting for the next full take
        self.failures = 0  # batches whose callback raised (logged, the thread goes on)
        # when the last take started: what was pending then is handed over
        self.last_take = time.monotonic()
        self._log = FailureLog(owner.get_logger())
        self._thread = threading.Thread(
            target=self._run, name=f"{owner.get_name()}-rx", daemon=True
        )
        self._thread.start()

    def add(self, topic: BatchTopic) -> None:
        """Take one more topic from the next wake-up on (or the same topic with another QoS)."""
        with self._lock:
            self._new.append(topic)

    def _subscribe_new(self) -> None:
        with self._lock:
            new, self._new = self._new, []
        for t in new:
            name = self.owner.resolve_topic_name(t.topic)
            # a new QoS for a topic taken already: replace its subscription
            if name in self._topics:
                i = self._topics.index(name)
                self.node.destroy_subscription(self.subs[i][0])
                del self.subs[i], self._topics[i]
            sub = self.node.create_subscription(t.msg_type, name, lambda m: None, t.qos, raw=True)
            self.subs.append((sub, t.on_batch))
            self._topics.append(name)

    def drain(self, timeout_s: float) -> bool:
        """Return once every message the subscriptions hold now has been handed over (one full
        take started after this call), or after ``timeout_s``: False then, or if the thread is
        gone."""
        done = threading.Event()
        with self._lock:
            self._drains.append(done)
        return self._thread.is_alive() and done.wait(timeout_s)

    def _real_time(self) -> None:
        """SCHED_FIFO for this thread (Linux: the calling thread), so that a busy machine does
        not starve a deadline-bound intake (the ctc's); without the privilege, a warning."""
        what = f"the intake of {', '.join(t.topic for t in self._new)}"
        e = real_time_thread(self.rt_priority)
        if e is not None:
            self.owner.get_logger().warning(
                f"no real-time priority for {what} ({e}): it may fall behind when the machine "
                "is busy (rt_priority:=0 silences this)")
            return
        self.owner.get_logger().info(f"{what} at real-time priority {self.rt_priority} "
                                     "(SCHED_FIFO)")

    def _run(self) -> None:
        ctx = self.node.context
        if self.rt_priority > 0:
            self._real_time()
        try:
            while not self._stop.is_set() and ctx.ok():
                # these calls are served by the take below, which starts after them
                with self._lock:
                    drains, self._drains = self._drains, []
                self._subscribe_new()
                if self.subs:
                    if not drains:
                        self._wait(ctx)
                    self.last_take = time.monotonic()
                    for (sub, on_batch), topic in zip(self.subs, self._topics):
                        batch = self._take_all(sub)
                        if batch:
                            self._hand_over(on_batch, batch, topic)
                    if self.on_wake is not None:
                        self._hand_over(lambda _: self.on_wake(), [], "wake-up")
                for d in drains:
                    d.set()
                if not self.subs:
                    self._stop.wait(0.1)
                elif self.period_s:
                    time.sleep(self.period_s)  # let messages gather: one wake-up takes them all
        except (InvalidHandle, RuntimeError) as exc:
            if not self._stop.is_set() and ctx.ok():
                cannot_go_on(
                    self.owner,
                    f"its intake of {', '.join(self._topics)} failed: {type(exc).__name__}: {exc}",
                )
        except Exception as exc:  # noqa: BLE001 - a node deaf to its topics must not stay up
            cannot_go_on(
                self.owner,
                f"its intake of {', '.join(self._topics)} failed: {type(exc).__name__}: {exc}",
            )
        # else: closed, or shutting down

    def _hand_over(self, on_batch: Callable[[Batch], None], batch: Batch, topic: str) -> None:
        """One call of the owner's callback; its failure is logged and the thread goes on (a
        dead thread would leave the node up but deaf to the topic, saying nothing)."""
        try:
            on_batch(batch)
        except Exception as exc:  # noqa: BLE001 - any bug in a callback, reported with its reason
            self.failures += 1
            self._log.failed(f"{topic}: the batch callback", exc,
                             f"{len(batch)} message(s) lost, the intake goes on")

    def _wait(self, ctx: Any) -> None:
        with ctx.handle:
            wait_set = _rclpy.WaitSet(len(self.subs), 0, 0, 0, 0, 0, ctx.handle)
            wait_set.clear_entities()
            for sub, _ in self.subs:
                wait_set.add_subscription(sub.handle)
            wait_set.wait(self.wake_ns)  # 0.1 s at most by default, so that close() is seen

    @staticmethod
    def _take_all(sub: Any) -> Batch:
        out = []
        while True:
            with sub.handle:
                taken = sub.handle.take_message(sub.msg_type, True)
            if taken is None:
                return out
            out.append((taken[0], taken[1]["received_timestamp"], taken[1]["source_timestamp"]))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.node.destroy_node()
