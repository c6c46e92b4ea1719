// roslib (roslibjs) 2.x's TF clients from Node against robotrial's rosbridge server: the
// ROS 1 TFClient (tf2_web_republisher over actionlib), the ROS2TFClient (a ROS 2 action)
// and the ROS 2 /republish_tfs service with its TFArray topic.
// Usage: node tf.mjs ws://127.0.0.1:PORT/rosbridge
// Prints one JSON object of results on stdout; exits 1 with the error on stderr on failure.
import { ROS2TFClient, Ros, Service, TFClient, Topic } from "roslib";

const url = process.argv[2];
const ros = new Ros({ url });

function within(ms, what, fn) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`timed out: ${what}`)), ms);
    fn((v) => {
      clearTimeout(timer);
      resolve(v);
    });
  });
}

const plain = (t) => ({
  translation: { x: t.translation.x, y: t.translation.y, z: t.translation.z },
  rotation: { x: t.rotation.x, y: t.rotation.y, z: t.rotation.z, w: t.rotation.w },
});

function twoTransforms(client, frame, what) {
  return within(10000, what, (ok) => {
    const got = [];
    client.subscribe(frame, (t) => {
      got.push(plain(t));
      if (got.length === 2) {
        client.dispose();
        ok(got);
      }
    });
  });
}

async function main() {
  await within(5000, "connect", (ok) => ros.on("connection", ok));
  const options = { ros, fixedFrame: "odom", angularThres: 0.001, transThres: 0.001, rate: 20 };
  const ros1 = await twoTransforms(new TFClient(options), "lidar_link", "TFClient");
  const ros2 = await twoTransforms(new ROS2TFClient(options), "/lidar_link", "ROS2TFClient");
  const republish = new Service({
    ros,
    name: "/republish_tfs",
    serviceType: "tf2_web_republisher_interfaces/srv/RepublishTFs",
  });
  const answer = await within(5000, "republish_tfs", (ok) =>
    republish.callService(
      {
        source_frames: ["lidar_link"],
        target_frame: "odom",
        angular_thres: 0.001,
        trans_thres: 0.001,
        rate: 20,
        timeout: { sec: 5, nanosec: 0 },
      },
      ok,
    ),
  );
  const topic = new Topic({
    ros,
    name: answer.topic_name,
    messageType: "tf2_web_republisher_interfaces/msg/TFArray",
  });
  const array = await within(5000, "TFArray", (ok) =>
    topic.subscribe((m) => {
      topic.unsubscribe();
      ok(m);
    }),
  );
  console.log(JSON.stringify({ ros1, ros2, topic: answer.topic_name, array }));
  ros.close();
}

main().catch((e) => {
  console.error(e.stack || String(e));
  process.exit(1);
});
