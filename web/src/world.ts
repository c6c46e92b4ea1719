// A world (room, desk scene) loaded from the server's scene glTF: static geometry the
// robot stands in. The robot's place in it is the world's spawn pose (then its own stand:
// a robot whose legs reach below the floor is lifted onto it, as the server places it).

import { Group, Light, Matrix4, type Object3D, Quaternion, Vector3 } from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";
import type { SpawnPose } from "./api";
import { enableShadows } from "./scene";

/** Fetch and parse a world's glTF scene, ready to cast and receive shadows. */
export async function loadWorld(url: string): Promise<Object3D> {
  const gltf = await new GLTFLoader().loadAsync(url);
  const world = gltf.scene;
  // The viewer lights every scene the same way (a sun with shadows and a soft sky).
  world.traverse((o) => {
    if (o instanceof Light) o.visible = false;
  });
  enableShadows(world);
  return world;
}

/** `stand` (a pose relative to `spawn`) in the world's frame. */
export function standing(spawn: SpawnPose, stand: SpawnPose): SpawnPose {
  const matrix = (p: SpawnPose) =>
    new Matrix4().compose(new Vector3(...p.xyz), new Quaternion(...p.quat), new Vector3(1, 1, 1));
  const position = new Vector3();
  const quaternion = new Quaternion();
  matrix(spawn).multiply(matrix(stand)).decompose(position, quaternion, new Vector3());
  return { xyz: position.toArray(), quat: quaternion.toArray() as [number, number, number, number] };
}

/** A group holding `robot` at the world's spawn pose. */
export function placeAt(robot: Object3D, spawn: SpawnPose): Group {
  const placed = new Group();
  placed.name = "robot";
  placed.position.set(...spawn.xyz);
  placed.quaternion.set(...spawn.quat);
  placed.add(robot);
  return placed;
}
