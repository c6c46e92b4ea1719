// A small TF buffer for the live view: the latest transform of every frame from /tf and
// /tf_static, and the pose of any frame in the page's world, given where the root frames
// of the tree (map, odom) sit in it.

import { Matrix4, Quaternion, Vector3 } from "three";
import type { TFMessage, Transform } from "../generated/msgs";

interface Edge {
  parent: string;
  matrix: Matrix4;
}

export function transformMatrix(t: Transform): Matrix4 {
  const { translation: p, rotation: q } = t;
  return new Matrix4().compose(
    new Vector3(p.x, p.y, p.z),
    new Quaternion(q.x, q.y, q.z, q.w),
    new Vector3(1, 1, 1),
  );
}

/** Frames by child name; frame ids are compared without a leading slash (ROS 1 style). */
export class TfBuffer {
  private readonly edges = new Map<string, Edge>();

  /** Take every transform of a /tf or /tf_static message. */
  add(message: TFMessage): void {
    for (const t of message.transforms) {
      this.edges.set(frameId(t.child_frame_id), {
        parent: frameId(t.header.frame_id),
        matrix: transformMatrix(t.transform),
      });
    }
  }

  clear(): void {
    this.edges.clear();
  }

  /** The pose of `frame` in the world: up its parents to the tree's root, then the
   * root's place in the world (`roots`); null if the chain is broken or its root is not
   * one of `roots`. */
  inWorld(frame: string, roots: ReadonlyMap<string, Matrix4>): Matrix4 | null {
    let name = frameId(frame);
    const chain = new Matrix4();
    for (let depth = 0; depth < 64; depth++) {
      const root = roots.get(name);
      const edge = this.edges.get(name);
      if (!edge) return root ? root.clone().multiply(chain) : null;
      chain.premultiply(edge.matrix);
      name = edge.parent;
    }
    return null;
  }

  has(frame: string): boolean {
    return this.edges.has(frameId(frame));
  }
}

export function frameId(name: string): string {
  return name.startsWith("/") ? name.slice(1) : name;
}
