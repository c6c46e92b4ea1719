"""rosgraph_msgs: Clock, the simulated time on /clock (what `use_sim_time` nodes follow)."""

from __future__ import annotations

from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.core import Message, message


@message("rosgraph_msgs/msg/Clock")
class Clock(Message):
    clock: Time
