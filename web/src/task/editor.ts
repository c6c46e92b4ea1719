// The task in the 3D view: obstacle boxes, the object to carry and the hand's goal,
// each picked by a click and moved, turned or resized with a three.js TransformControls
// gizmo. Boxes stay upright (they turn about z only) and never sink below the surface
// the robot stands on (z = 0 in its base frame: the table top or the floor). Also draws
// the hand's planned and simulated paths.

import {
  BoxGeometry,
  BufferGeometry,
  Color,
  EdgesGeometry,
  Group,
  Line,
  LineBasicMaterial,
  LineDashedMaterial,
  LineSegments,
  Matrix4,
  Mesh,
  MeshStandardMaterial,
  Raycaster,
  SphereGeometry,
  TorusGeometry,
  Vector2,
  Vector3,
  type Object3D,
} from "three";
import { TransformControls } from "three/examples/jsm/controls/TransformControls.js";
import type { Viewer } from "../scene";
import type { Quat, Vec3 } from "../types";
import type { TaskBox } from "./arrangement";

export type GizmoMode = "translate" | "rotate" | "scale";
/** What can be picked: an obstacle by id, the object, or the goal. */
export type Pick = { kind: "obstacle"; id: string } | { kind: "object" } | { kind: "goal" };

const MIN_SIZE = 0.01; // m
const COLORS = {
  obstacle: 0xe07b39,
  object: 0x2f9e5b,
  goal: 0xd1384a,
  planned: 0x386fd1,
  simulated: 0xe0a100,
};

export class TaskEditor {
  /** The task's objects, in the robot's base frame; the app places it at the spawn. */
  readonly group = new Group();
  private readonly gizmo: TransformControls;
  private readonly boxes = new Map<string, Mesh>();
  private objectMesh: Mesh | null = null;
  private readonly goalMarker: Group;
  private readonly paths = new Group();
  private selected: Pick | null = null;
  private mode: GizmoMode = "translate";
  private locked = false;
  private readonly down = new Vector2();

  /** `changed` runs after the user moved something with the gizmo. */
  constructor(
    private readonly viewer: Viewer,
    private readonly changed: (pick: Pick) => void,
    private readonly picked: (pick: Pick | null) => void,
  ) {
    this.group.name = "task";
    this.goalMarker = goalMarker();
    this.group.add(this.goalMarker, this.paths);
    viewer.scene.add(this.group);

    const canvas = viewer.renderer.domElement;
    this.gizmo = new TransformControls(viewer.camera, canvas);
    this.gizmo.setSize(0.8);
    this.gizmo.addEventListener("change", () => viewer.requestRender());
    this.gizmo.addEventListener("dragging-changed", (e) => {
      viewer.controls.enabled = !(e as unknown as { value: boolean }).value;
    });
    this.gizmo.addEventListener("objectChange", () => this.afterGizmo());
    viewer.scene.add(this.gizmo.getHelper());

    canvas.addEventListener("pointerdown", (e) => this.down.set(e.clientX, e.clientY));
    canvas.addEventListener("pointerup", (e) => this.click(e));
  }

  // --- contents --------------------------------------------------------------------

  obstacles(): TaskBox[] {
    return [...this.boxes].map(([id, mesh]) => boxOf(id, mesh));
  }

  object(): TaskBox | null {
    return this.objectMesh ? boxOf("object", this.objectMesh) : null;
  }

  goal(): Vec3 {
    const p = this.goalMarker.position;
    return [p.x, p.y, p.z];
  }

  /** Add or replace an obstacle box. */
  putObstacle(box: TaskBox): void {
    let mesh = this.boxes.get(box.id);
    if (!mesh) {
      mesh = boxMesh(COLORS.obstacle, 0.55);
      mesh.userData.pick = { kind: "obstacle", id: box.id } satisfies Pick;
      this.boxes.set(box.id, mesh);
      this.group.add(mesh);
    }
    place(mesh, box);
    keepAbove(mesh);
    this.viewer.requestRender();
  }

  removeObstacle(id: string): void {
    const mesh = this.boxes.get(id);
    if (!mesh) return;
    if (this.selected?.kind === "obstacle" && this.selected.id === id) this.select(null);
    this.group.remove(mesh);
    this.boxes.delete(id);
    this.viewer.requestRender();
  }

  clearObstacles(): void {
    for (const id of [...this.boxes.keys()]) this.removeObstacle(id);
  }

  /** Show the object to carry at `box` (null: none). */
  setObject(box: TaskBox | null): void {
    if (!box) {
      if (this.selected?.kind === "object") this.select(null);
      if (this.objectMesh) this.group.remove(this.objectMesh);
      this.objectMesh = null;
    } else {
      if (!this.objectMesh) {
        this.objectMesh = boxMesh(COLORS.object, 0.95);
        this.objectMesh.userData.pick = { kind: "object" } satisfies Pick;
        this.group.add(this.objectMesh);
      }
      place(this.objectMesh, box);
    }
    this.viewer.requestRender();
  }

  /** Move the object without the surface check (physics decides where it is). */
  moveObject(position: Vec3, quaternion: Quat): void {
    if (!this.objectMesh) return;
    this.objectMesh.position.set(...position);
    this.objectMesh.quaternion.set(...quaternion);
    this.viewer.requestRender();
  }

  setGoal(goal: Vec3): void {
    this.goalMarker.position.set(goal[0], goal[1], Math.max(0, goal[2]));
    this.viewer.requestRender();
  }

  /** Draw the hand's planned path (dashed) and simulated path (solid); empty: none. */
  showPaths(planned: Vec3[], simulated: Vec3[]): void {
    for (const old of [...this.paths.children]) {
      this.paths.remove(old);
      (old as Line).geometry.dispose();
    }
    if (planned.length > 1) {
      const line = new Line(
        lineGeometry(planned),
        new LineDashedMaterial({ color: COLORS.planned, dashSize: 0.01, gapSize: 0.006 }),
      );
      line.computeLineDistances();
      this.paths.add(line);
    }
    if (simulated.length > 1) {
      this.paths.add(
        new Line(lineGeometry(simulated), new LineBasicMaterial({ color: COLORS.simulated })),
      );
    }
    this.viewer.requestRender();
  }

  // --- editing -----------------------------------------------------------------------

  /** Locked: nothing can be picked or moved (the robot is set or moving). */
  setLocked(locked: boolean): void {
    this.locked = locked;
    if (locked) this.select(null);
  }

  setMode(mode: GizmoMode): void {
    this.mode = mode;
    this.configureGizmo();
  }

  /** Attach the gizmo to `pick` (null: detach). */
  select(pick: Pick | null): void {
    const target = pick ? this.objectFor(pick) : null;
    this.selected = target ? pick : null;
    if (target && !this.locked) this.gizmo.attach(target);
    else this.gizmo.detach();
    this.configureGizmo();
    this.picked(this.selected);
    this.viewer.requestRender();
  }

  private configureGizmo(): void {
    // The goal is a point: it only moves. Boxes turn about z only, so they stay upright.
    const mode = this.selected?.kind === "goal" ? "translate" : this.mode;
    this.gizmo.setMode(mode);
    this.gizmo.showX = mode !== "rotate";
    this.gizmo.showY = mode !== "rotate";
    this.gizmo.showZ = true;
    this.gizmo.setSpace(mode === "translate" ? "world" : "local");
    this.viewer.requestRender();
  }

  private objectFor(pick: Pick): Object3D | null {
    if (pick.kind === "goal") return this.goalMarker;
    if (pick.kind === "object") return this.objectMesh;
    return this.boxes.get(pick.id) ?? null;
  }

  private afterGizmo(): void {
    const target = this.gizmo.object;
    const pick = this.selected;
    if (!target || !pick) return;
    if (target instanceof Mesh) {
      target.scale.set(
        Math.max(MIN_SIZE, Math.abs(target.scale.x)),
        Math.max(MIN_SIZE, Math.abs(target.scale.y)),
        Math.max(MIN_SIZE, Math.abs(target.scale.z)),
      );
      keepAbove(target);
    } else {
      target.position.z = Math.max(0, target.position.z);
    }
    this.changed(pick);
  }

  private click(e: PointerEvent): void {
    if (this.locked || e.button !== 0) return;
    if (this.down.distanceTo(new Vector2(e.clientX, e.clientY)) > 4) return;
    if (this.gizmo.dragging || this.gizmo.axis !== null) return;
    const rect = this.viewer.renderer.domElement.getBoundingClientRect();
    const ndc = new Vector2(
      ((e.clientX - rect.left) / rect.width) * 2 - 1,
      -((e.clientY - rect.top) / rect.height) * 2 + 1,
    );
    const ray = new Raycaster();
    ray.setFromCamera(ndc, this.viewer.camera);
    const candidates = [...this.boxes.values(), this.goalMarker];
    if (this.objectMesh) candidates.push(this.objectMesh);
    const hit = ray.intersectObjects(candidates, true)[0];
    let node: Object3D | null = hit ? hit.object : null;
    while (node && !node.userData.pick) node = node.parent;
    this.select(node ? (node.userData.pick as Pick) : null);
  }
}

/** A unit box scaled to its size, with its edges drawn. */
function boxMesh(color: number, opacity: number): Mesh {
  const mesh = new Mesh(
    new BoxGeometry(1, 1, 1),
    new MeshStandardMaterial({
      color,
      transparent: opacity < 1,
      opacity,
      roughness: 0.7,
      depthWrite: opacity >= 0.9,
    }),
  );
  mesh.castShadow = true;
  mesh.receiveShadow = true;
  const edges = new LineSegments(
    new EdgesGeometry(new BoxGeometry(1, 1, 1)),
    new LineBasicMaterial({ color: new Color(color).multiplyScalar(0.6) }),
  );
  mesh.add(edges);
  return mesh;
}

function goalMarker(): Group {
  const marker = new Group();
  marker.name = "goal";
  marker.userData.pick = { kind: "goal" } satisfies Pick;
  const material = new MeshStandardMaterial({ color: COLORS.goal, roughness: 0.5 });
  const dot = new Mesh(new SphereGeometry(0.009, 20, 12), material);
  const ring = new Mesh(new TorusGeometry(0.025, 0.003, 8, 40), material);
  marker.add(dot, ring);
  return marker;
}

function place(mesh: Mesh, box: TaskBox): void {
  mesh.position.set(...box.position);
  mesh.quaternion.set(...box.quaternion).normalize();
  mesh.scale.set(...(box.size.map((s) => Math.max(MIN_SIZE, s)) as Vec3));
}

function boxOf(id: string, mesh: Mesh): TaskBox {
  const q = mesh.quaternion;
  return {
    id,
    size: [mesh.scale.x, mesh.scale.y, mesh.scale.z],
    position: [mesh.position.x, mesh.position.y, mesh.position.z],
    quaternion: [q.x, q.y, q.z, q.w],
  };
}

/** Lift a box so that its lowest corner is on or above z = 0. */
function keepAbove(mesh: Mesh): void {
  const r = new Matrix4().makeRotationFromQuaternion(mesh.quaternion).elements;
  // Column-major: row 2 of the rotation is elements 2, 6, 10.
  const s = mesh.scale;
  const halfHeight = (Math.abs(r[2]) * s.x + Math.abs(r[6]) * s.y + Math.abs(r[10]) * s.z) / 2;
  mesh.position.z = Math.max(mesh.position.z, halfHeight);
}

function lineGeometry(points: Vec3[]): BufferGeometry {
  return new BufferGeometry().setFromPoints(points.map((p) => new Vector3(...p)));
}
