// roslib (roslibjs) 2.x from Node against robotrial's rosbridge server.
// Usage: node interop.mjs ws://127.0.0.1:PORT/rosbridge
// Prints one JSON object of results on stdout; exits 1 with the error on stderr on failure.
import { Param, Ros, Service, Topic } from "roslib";

const url = process.argv[2];
const ros = new Ros({ url });

function within(ms, what, fn) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`timed out: ${what}`)), ms);
    fn(
      (v) => {
        clearTimeout(timer);
        resolve(v);
      },
      (e) => {
        clearTimeout(timer);
        reject(new Error(`${what}: ${e}`));
      },
    );
  });
}

function firstMessages(topic, count, what) {
  return within(5000, what, (ok) => {
    const got = [];
    topic.subscribe((m) => {
      got.push(m);
      if (got.length === count) {
        topic.unsubscribe();
        ok(got);
      }
    });
  });
}

const results = {};
await within(5000, "connect", (ok, fail) => {
  ros.on("connection", ok);
  ros.on("error", fail);
});

results.topics = await within(5000, "getTopics", (ok, fail) => ros.getTopics(ok, fail));
results.services = await within(5000, "getServices", (ok, fail) => ros.getServices(ok, fail));

const plan = new Service({
  ros,
  name: "/robotrial/plan_task",
  serviceType: "robotrial_msgs/srv/PlanTask",
});
results.plan = await within(5000, "plan_task", (ok, fail) =>
  plan.callService(
    {
      current_joints: { name: ["j1", "j2"], position: [0.1, 0.2] },
      obstacles: [{ id: "box", size: { x: 0.1, y: 0.1, z: 0.1 }, pose: { position: { x: 0.3 } } }],
      ee_goal: { position: { x: 0.3, y: 0.0, z: 0.2 } },
    },
    ok,
    fail,
  ),
);

results.missing = await within(5000, "call of a missing service", (ok) =>
  new Service({ ros, name: "/no/such/service", serviceType: "std_srvs/srv/Trigger" }).callService(
    {},
    () => ok("unexpected success"),
    (err) => ok(String(err)),
  ),
);

const joints = (compression) =>
  new Topic({ ros, name: "/joint_states", messageType: "sensor_msgs/msg/JointState", compression });
const json = await firstMessages(joints("none"), 3, "joint_states json");
results.joint_states_json = json.map((m) => ({ name: m.name, position: Array.from(m.position) }));
const cbor = await firstMessages(joints("cbor"), 3, "joint_states cbor");
results.joint_states_cbor = cbor.map((m) => ({
  name: m.name,
  position: Array.from(m.position),
  typed: m.position instanceof Float64Array,
}));

const mapPng = new Topic({
  ros,
  name: "/map",
  messageType: "nav_msgs/msg/OccupancyGrid",
  compression: "png",
});
const [map] = await firstMessages(mapPng, 1, "latched /map over png");
results.map_png = { width: map.info.width, height: map.info.height, cells: map.data.length };

// server-side fragmentation: subscribe by hand with a fragment_size
results.map_fragments = await within(5000, "fragmented /map", (ok) => {
  const handler = (message) => {
    ros.off("/map", handler);
    ros.callOnConnection({ op: "unsubscribe", topic: "/map", id: "frag" });
    ok({ cells: message.msg.data.length, width: message.msg.info.width });
  };
  ros.on("/map", handler);
  ros.callOnConnection({ op: "subscribe", topic: "/map", id: "frag", fragment_size: 200 });
});

// publish from Node; the Python side records /cmd_vel
const cmd = new Topic({ ros, name: "/cmd_vel", messageType: "geometry_msgs/msg/Twist" });
cmd.advertise();
for (let i = 0; i < 3; i++) {
  cmd.publish({ linear: { x: 0.5, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.25 } });
}

// a service offered by this client, called by another client object through the server
const offered = new Service({
  ros,
  name: "/node/add_two_ints",
  serviceType: "example_interfaces/srv/AddTwoInts",
});
await offered.advertise((request, response) => {
  response.sum = request.a + request.b;
  return true;
});
await new Promise((r) => setTimeout(r, 200));
results.offered = await within(5000, "call of the client's own service", (ok, fail) =>
  new Service({
    ros,
    name: "/node/add_two_ints",
    serviceType: "example_interfaces/srv/AddTwoInts",
  }).callService({ a: 2, b: 40 }, ok, fail),
);

results.details = await within(5000, "getMessageDetails", (ok, fail) =>
  ros.getMessageDetails("sensor_msgs/msg/JointState", ok, fail),
);
results.decoded = ros.decodeTypeDefs(results.details);

const param = new Param({ ros, name: "/robot_name" });
await within(5000, "set_param", (ok, fail) => param.set("tiny_arm", ok, fail));
results.param = await within(5000, "get_param", (ok, fail) => param.get(ok, fail));
results.params = await within(5000, "getParams", (ok, fail) => ros.getParams(ok, fail));

// a malformed operation gets a status error with its id; the connection stays up
results.status = await within(5000, "status for a bad op", (ok) => {
  ros.once("status:bad-1", (m) => ok({ level: m.level, msg: m.msg }));
  ros.callOnConnection({ op: "subscribe", id: "bad-1", topic: 42 });
});
results.after_error = await within(5000, "getNodes after the error", (ok, fail) =>
  ros.getNodes(ok, fail),
);

await offered.unadvertise();
cmd.unadvertise();
process.stdout.write(JSON.stringify(results));
ros.close();
setTimeout(() => process.exit(0), 100);
