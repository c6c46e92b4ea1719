"""The in-process bus: topics, latching, typed services, nodes, threads and asyncio."""

from __future__ import annotations

import asyncio
import threading

import pytest

from robotrial.msgs import MessageError
from robotrial.msgs.geometry_msgs import Twist, Vector3
from robotrial.msgs.robotrial_msgs import PlanTask
from robotrial.msgs.std_msgs import String
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.ros.bus import (
    Bus,
    BusError,
    Node,
    ServiceFailed,
    ServiceNotFound,
    current_call,
)


def test_publish_reaches_subscribers_with_typed_messages() -> None:
    bus = Bus()
    got: list = []
    bus.subscribe("/cmd_vel", got.append, Twist)
    pub = bus.advertise("/cmd_vel", "geometry_msgs/Twist")
    pub.publish(Twist(linear=Vector3(x=1.0)))
    pub.publish({"angular": {"z": 0.5}})  # rosbridge-style dicts become typed messages
    assert [m.linear.x for m in got] == [1.0, 0.0]
    assert got[1].angular.z == 0.5
    with pytest.raises(MessageError, match="no field 'bogus'"):
        pub.publish({"bogus": 1})
    with pytest.raises(MessageError, match="expected geometry_msgs/msg/Twist"):
        pub.publish(String(data="x"))


def test_type_clash_is_refused() -> None:
    bus = Bus()
    bus.advertise("/scan", "sensor_msgs/msg/LaserScan")
    bus.advertise("/scan", "sensor_msgs/LaserScan")  # the same type, other spelling
    with pytest.raises(BusError, match="has type sensor_msgs/msg/LaserScan"):
        bus.advertise("/scan", String)
    with pytest.raises(BusError, match="must start with '/'"):
        bus.advertise("scan", String)


def test_latched_topics_keep_each_publishers_last_message() -> None:
    bus = Bus()
    a = bus.advertise("/tf_static", TFMessage)
    b = bus.advertise("/tf_static", TFMessage)
    a.publish(TFMessage.from_dict({"transforms": [{"child_frame_id": "old"}]}))
    a.publish(TFMessage.from_dict({"transforms": [{"child_frame_id": "arm"}]}))
    b.publish(TFMessage.from_dict({"transforms": [{"child_frame_id": "camera"}]}))
    late: list = []
    bus.subscribe("/tf_static", late.append)
    assert sorted(m.transforms[0].child_frame_id for m in late) == ["arm", "camera"]
    b.close()
    later: list = []
    bus.subscribe("/tf_static", later.append)
    assert [m.transforms[0].child_frame_id for m in later] == ["arm"]
    # not latched: a late subscriber gets nothing old
    bus.publish("/chatter", String(data="gone"))
    missed: list = []
    bus.subscribe("/chatter", missed.append)
    assert missed == []


def test_typed_service_calls_from_threads_and_coroutines() -> None:
    bus = Bus()

    def plan(req):
        if not req.current_joints.position:
            raise ValueError("no start configuration")
        return {"success": True, "goal_joints": [2 * p for p in req.current_joints.position]}

    bus.advertise_service("/robotrial/plan_task", PlanTask, plan)
    resp = bus.call("/robotrial/plan_task", {"current_joints": {"position": [1.0]}})
    assert isinstance(resp, PlanTask.Response) and resp.goal_joints == [2.0]
    with pytest.raises(ServiceFailed, match="no start configuration"):
        bus.call("/robotrial/plan_task", PlanTask.Request())
    with pytest.raises(ServiceNotFound):
        bus.call("/nobody")
    with pytest.raises(BusError, match="already offered"):
        bus.advertise_service("/robotrial/plan_task", PlanTask, plan)

    results: list = []
    threads = [
        threading.Thread(
            target=lambda i=i: results.append(
                bus.call("/robotrial/plan_task", {"current_joints": {"position": [float(i)]}})
            )
        )
        for i in range(8)
    ]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(r.goal_joints[0] for r in results) == [2.0 * i for i in range(8)]

    async def from_coroutine() -> list:
        return await asyncio.gather(
            *(
                bus.call_async("/robotrial/plan_task", {"current_joints": {"position": [3.0]}})
                for _ in range(4)
            )
        )

    assert [r.goal_joints for r in asyncio.run(from_coroutine())] == [[6.0]] * 4


def test_async_handlers_and_subscribers_run_on_their_loop() -> None:
    bus = Bus()
    ready = threading.Event()
    stop = threading.Event()
    seen_threads: set = set()
    received: list = []

    async def handler(req):
        seen_threads.add(threading.get_ident())
        await asyncio.sleep(0.01)
        return {"success": req.data}

    async def on_msg(msg):
        seen_threads.add(threading.get_ident())
        received.append(msg.data)

    def loop_thread() -> None:
        async def main() -> None:
            bus.advertise_service("/toggle", "std_srvs/srv/SetBool", handler)
            bus.subscribe("/chatter", on_msg, String)
            ready.set()
            while not stop.is_set():
                await asyncio.sleep(0.01)

        asyncio.run(main())

    t = threading.Thread(target=loop_thread)
    t.start()
    ready.wait(5)
    loop_ident = t.ident
    assert bus.call("/toggle", {"data": True}, timeout=5).success is True
    bus.publish("/chatter", String(data="from main"))
    with pytest.raises(TimeoutError):
        bus.call("/toggle", {"data": True}, timeout=0.001)
    deadline = threading.Event()
    deadline.wait(0.2)
    stop.set()
    t.join(5)
    assert received == ["from main"]
    assert seen_threads == {loop_ident}


def test_node_destroy_removes_everything() -> None:
    bus = Bus()
    ticks = threading.Event()

    class Mapper(Node):
        def __init__(self, bus: Bus) -> None:
            super().__init__(bus, "mapper")
            self.pub = self.create_publisher("/map", "nav_msgs/msg/OccupancyGrid")
            self.create_subscription("/scan", "sensor_msgs/msg/LaserScan", lambda m: None)
            self.create_service("/mapper/reset", "std_srvs/srv/Empty", lambda r: {})
            self.create_timer(0.01, ticks.set)

    with Mapper(bus) as node:
        assert bus.nodes() == ["/mapper"]
        assert bus.node_details("/mapper") == {
            "publishing": ["/map"],
            "subscribing": ["/scan"],
            "services": ["/mapper/reset"],
        }
        assert ticks.wait(2)
        with pytest.raises(BusError, match="already exists"):
            Node(bus, "/mapper")
    assert node.bus.nodes() == []
    assert bus.topics() == {} and bus.services() == {}


def test_a_failing_subscriber_does_not_stop_the_others(caplog) -> None:
    bus = Bus()
    got: list = []

    def broken(msg):
        raise RuntimeError("subscriber bug")

    bus.subscribe("/chatter", broken, String)
    bus.subscribe("/chatter", got.append, String)
    bus.publish("/chatter", String(data="x"))
    assert [m.data for m in got] == ["x"]
    assert "subscriber bug" in caplog.text


def test_a_threaded_handler_learns_that_its_caller_has_gone() -> None:
    """A caller that times out marks the call abandoned, so a long handler can stop;
    the handler sees the call's deadline too."""
    bus = Bus()
    seen: dict = {}
    done = threading.Event()

    def slow(request):
        call = current_call()
        seen["deadline"] = call.remaining()
        seen["abandoned"] = call.abandoned.wait(10)
        done.set()
        return {}

    bus.advertise_service("/slow", "std_srvs/srv/Trigger", slow)

    async def ask() -> None:
        with pytest.raises(TimeoutError, match=r"did not answer within 0\.2 s"):
            await bus.call_async("/slow", {}, timeout=0.2)

    asyncio.run(ask())
    assert done.wait(10)
    assert seen["abandoned"] is True
    assert 0 < seen["deadline"] <= 0.2
    assert current_call() is None  # only inside a handler
