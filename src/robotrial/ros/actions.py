"""Actions on the bus: goals with an id, feedback, a final status and cancel (layer 4).

An `ActionServer` registers itself in `bus.actions` under its name. A client sends a goal
with `send_goal` and gets a `GoalHandle`; the server's `execute` callback receives the
same handle, may refuse it by raising `GoalRejected`, and later calls `feedback` and one
of `succeed` / `abort` / `canceled`. Everything runs in the caller's thread, so callbacks
must be quick (like bus subscriptions). Status codes are ROS 2's action_msgs/GoalStatus.
"""

from __future__ import annotations

import logging
import threading
import uuid
from collections.abc import Callable

from robotrial.msgs import ActionType, Message, lookup_action
from robotrial.ros.bus import Bus, BusError, check_name

log = logging.getLogger(__name__)

UNKNOWN, ACCEPTED, EXECUTING, CANCELING, SUCCEEDED, CANCELED, ABORTED = range(7)
TERMINAL = (SUCCEEDED, CANCELED, ABORTED)

FeedbackCallback = Callable[[Message], None]
ResultCallback = Callable[["GoalHandle"], None]


class GoalRejected(BusError):
    """Raised by an action server's `execute` to refuse a goal; the text says why."""


class GoalHandle:
    """One goal: what was asked, its status, and how to report on it."""

    def __init__(
        self,
        server: ActionServer,
        goal: Message,
        on_feedback: FeedbackCallback | None,
        on_result: ResultCallback | None,
    ) -> None:
        self.server = server
        self.id = uuid.uuid4().hex
        self.goal = goal
        self.status = ACCEPTED
        self.result: Message | None = None
        self.message = ""  # why the goal ended as it did
        self.cancel_requested = False
        self._on_feedback = on_feedback
        self._on_result = on_result
        self._lock = threading.Lock()

    @property
    def active(self) -> bool:
        return self.status not in TERMINAL

    def feedback(self, msg: Message) -> None:
        """Send feedback to the client (ignored once the goal has ended)."""
        if self.active and self._on_feedback is not None:
            try:
                self._on_feedback(msg)
            except Exception:
                log.exception("action %s: feedback callback failed", self.server.name)

    def succeed(self, result: Message, message: str = "") -> None:
        self._finish(SUCCEEDED, result, message)

    def abort(self, result: Message, message: str) -> None:
        self._finish(ABORTED, result, message)

    def canceled(self, result: Message, message: str = "canceled") -> None:
        self._finish(CANCELED, result, message)

    def _finish(self, status: int, result: Message, message: str) -> None:
        with self._lock:
            if not self.active:
                return
            self.status, self.result, self.message = status, result, message
        self.server._goals.pop(self.id, None)
        if self._on_result is not None:
            try:
                self._on_result(self)
            except Exception:
                log.exception("action %s: result callback failed", self.server.name)


class ActionServer:
    """Offers action `name` of type `action_type` on the bus.

    `execute(handle)` is called for each new goal; `cancel(handle)` when a client asks to
    cancel it (the server then ends the goal with `handle.canceled`).
    """

    def __init__(
        self,
        bus: Bus,
        name: str,
        action_type: ActionType | str,
        execute: Callable[[GoalHandle], None],
        cancel: Callable[[GoalHandle], None],
        node: str = "/bus",
    ) -> None:
        check_name(name, "action")
        act = lookup_action(action_type) if isinstance(action_type, str) else action_type
        if act is None:
            raise BusError(f"action {name}: unknown action type {action_type!r}")
        self.bus, self.name, self.type, self.node = bus, name, act, node
        self._execute, self._cancel = execute, cancel
        self._goals: dict[str, GoalHandle] = {}
        with bus._lock:
            if name in bus.actions:
                raise BusError(f"action {name} is already offered by {bus.actions[name].node}")
            bus.actions[name] = self

    @property
    def type_name(self) -> str:
        return self.type.name

    def send_goal(
        self,
        goal: Message | dict,
        on_feedback: FeedbackCallback | None = None,
        on_result: ResultCallback | None = None,
    ) -> GoalHandle:
        """Start a goal; raises `GoalRejected` (or `MessageError` for a malformed goal)."""
        if isinstance(goal, dict):
            goal = self.type.Goal.from_dict(goal, f"{self.name} goal")
        elif not isinstance(goal, self.type.Goal):
            raise BusError(f"{self.name}: the goal must be a {self.type.Goal.__name__}")
        handle = GoalHandle(self, goal, on_feedback, on_result)
        self._goals[handle.id] = handle
        try:
            self._execute(handle)
        except Exception:
            self._goals.pop(handle.id, None)
            raise
        if handle.active:
            handle.status = EXECUTING
        return handle

    def cancel_goal(self, goal_id: str) -> bool:
        """Ask the server to cancel a goal; False when no such goal is running."""
        handle = self._goals.get(goal_id)
        if handle is None or not handle.active:
            return False
        handle.cancel_requested = True
        handle.status = CANCELING
        self._cancel(handle)
        return True

    def goals(self) -> list[GoalHandle]:
        """The goals still running."""
        return list(self._goals.values())

    def close(self) -> None:
        """Withdraw the action; running goals are aborted."""
        for handle in list(self._goals.values()):
            handle.abort(self.type.Result(), f"action {self.name} was withdrawn")
        with self.bus._lock:
            if self.bus.actions.get(self.name) is self:
                del self.bus.actions[self.name]


def action_server(bus: Bus, name: str) -> ActionServer:
    """The server offering action `name`, or a `BusError` saying it is not offered."""
    server = bus.actions.get(name)
    if server is None:
        raise BusError(f"action {name} is not offered")
    return server
