// A Foxglove WebSocket protocol client (@foxglove/ws-protocol) against robotrial's bridge:
// lists the channels, decodes /scan and /robot_description from their ros2msg schemas,
// publishes geometry_msgs/Twist on /cmd_vel in CDR. Prints one JSON object.
// Usage: node client.mjs ws://127.0.0.1:PORT [drive_seconds]
import wsProtocol from "@foxglove/ws-protocol";
import rosmsg from "@foxglove/rosmsg";
import serialization from "@foxglove/rosmsg2-serialization";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const { parse } = rosmsg;
const { MessageReader, MessageWriter } = serialization;

const url = process.argv[2];
const driveSeconds = Number(process.argv[3] ?? "3");
const WANTED = ["/scan", "/robot_description"];
const result = { channels: {}, decoded: {}, statuses: [] };

function fail(why) {
  console.error(why);
  process.exit(1);
}

const timer = setTimeout(() => fail(`timed out; so far: ${JSON.stringify(result)}`), 30000);
const client = new FoxgloveClient({
  ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]),
});
const channels = new Map(); // topic -> channel
const readers = new Map(); // subscription id -> [topic, reader]
let subscribed = false;

client.on("error", (err) => fail(`client error: ${err}`));
client.on("serverInfo", (info) => {
  result.server = { name: info.name, capabilities: info.capabilities, encodings: info.supportedEncodings };
});
client.on("status", (s) => result.statuses.push(s.message));
client.on("advertise", (list) => {
  for (const ch of list) {
    channels.set(ch.topic, ch);
    result.channels[ch.topic] = {
      schemaName: ch.schemaName,
      schemaEncoding: ch.schemaEncoding,
      encoding: ch.encoding,
    };
  }
  if (!subscribed && WANTED.every((t) => channels.has(t)) && channels.has("/cmd_vel")) {
    subscribed = true;
    for (const topic of WANTED) {
      const ch = channels.get(topic);
      const reader = new MessageReader(parse(ch.schema, { ros2: true }));
      readers.set(client.subscribe(ch.id), [topic, reader]);
    }
    drive();
  }
});
client.on("message", ({ subscriptionId, data }) => {
  const [topic, reader] = readers.get(subscriptionId) ?? [];
  if (topic === undefined || result.decoded[topic] !== undefined) return;
  const msg = reader.readMessage(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
  if (topic === "/scan") {
    result.decoded[topic] = {
      frame_id: msg.header.frame_id,
      ranges: msg.ranges.length,
      finite: Array.from(msg.ranges).filter((r) => Number.isFinite(r)).length,
      angle_min: msg.angle_min,
      angle_max: msg.angle_max,
    };
  } else {
    result.decoded[topic] = {
      head: msg.data.slice(0, 40),
      links: (msg.data.match(/<link /g) ?? []).length,
      length: msg.data.length,
    };
  }
  finishIfDone();
});

let driven = false;
function drive() {
  const ch = channels.get("/cmd_vel");
  const writer = new MessageWriter(parse(ch.schema, { ros2: true }));
  const id = client.advertise({
    topic: "/cmd_vel",
    encoding: "cdr",
    schemaName: ch.schemaName,
    schemaEncoding: "ros2msg",
    schema: ch.schema,
  });
  // A goal in JSON, on a topic the server does not have yet, as the 3D panel's pose tool.
  const goalChannel = client.advertise({
    topic: "/move_base_simple/goal",
    encoding: "json",
    schemaName: "geometry_msgs/msg/PoseStamped",
  });
  const goal = {
    header: { stamp: { sec: 0, nanosec: 0 }, frame_id: "map" },
    pose: { position: { x: 1.5, y: -0.5, z: 0 }, orientation: { x: 0, y: 0, z: 0, w: 1 } },
  };
  client.sendMessage(goalChannel, new TextEncoder().encode(JSON.stringify(goal)));
  const twist = { linear: { x: 0.5, y: 0, z: 0 }, angular: { x: 0, y: 0, z: 0.3 } };
  const bytes = writer.writeMessage(twist);
  const started = Date.now();
  let sent = 0;
  const every = setInterval(() => {
    client.sendMessage(id, bytes);
    sent += 1;
    if (Date.now() - started > driveSeconds * 1000) {
      clearInterval(every);
      // A message that is not a Twist: the bridge drops it and says why.
      client.sendMessage(id, new Uint8Array([0, 1, 0, 0, 7]));
      result.sent = sent;
      setTimeout(() => {
        driven = true;
        finishIfDone();
      }, 500);
    }
  }, 100);
}

function finishIfDone() {
  if (!driven || WANTED.some((t) => result.decoded[t] === undefined)) return;
  clearTimeout(timer);
  client.close();
  console.log(JSON.stringify(result));
  process.exit(0);
}
