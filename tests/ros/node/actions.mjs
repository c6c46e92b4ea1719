// roslib (roslibjs) 2.x's ROS 2 Action client against robotrial's rosbridge actions.
// Usage: node actions.mjs ws://127.0.0.1:PORT/
// Prints one JSON object of results on stdout; exits 1 with the error on stderr on failure.
import { Action, Ros } from "roslib";

const url = process.argv[2];
const ros = new Ros({ url });

function goal(action, args, cancelAfterFeedback = 0) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`timed out: ${action.name}`)), 20000);
    const feedback = [];
    const done = (outcome) => {
      clearTimeout(timer);
      resolve({ ...outcome, feedback });
    };
    const id = action.sendGoal(
      args,
      (result) => done({ result }),
      (f) => {
        feedback.push(f);
        if (cancelAfterFeedback && feedback.length === cancelAfterFeedback) {
          action.cancelGoal(id);
        }
      },
      (error) => done({ error }),
    );
  });
}

async function main() {
  await new Promise((resolve, reject) => {
    ros.on("connection", resolve);
    ros.on("error", reject);
  });
  const nav = new Action({
    ros,
    name: "/navigate_to_pose",
    actionType: "nav2_msgs/action/NavigateToPose",
  });
  const arm = new Action({
    ros,
    name: "/arm_controller/follow_joint_trajectory",
    actionType: "control_msgs/action/FollowJointTrajectory",
  });
  const pose = {
    header: { frame_id: "map" },
    pose: { position: { x: 0.5, y: 0.5, z: 0 }, orientation: { x: 0, y: 0, z: 0, w: 1 } },
  };
  const point = (positions, sec) => ({ positions, time_from_start: { sec, nanosec: 0 } });
  const out = {};
  out.nav = await goal(nav, { pose, behavior_tree: "" });
  out.unknown = await goal(arm, {
    trajectory: { joint_names: ["j1", "wrist"], points: [point([0.1, 0.1], 1)] },
  });
  out.canceled = await goal(
    arm,
    { trajectory: { joint_names: ["j1"], points: [point([2.0], 4)] } },
    20,
  );
  process.stdout.write(JSON.stringify(out));
  ros.close();
}

main().catch((e) => {
  process.stderr.write(String(e?.stack ?? e));
  process.exit(1);
});
