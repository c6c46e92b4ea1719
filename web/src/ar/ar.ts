// AR: the robot over the real room (WebXR immersive-ar). As in g2rViewer, the camera
// finds the floor (hit-test, and plane detection where the browser offers it); a
// reticle marks the spot under the centre of the view, the robot stands there at true
// scale as a preview, and a tap (the session's `select`) fixes it. Everything the 3D
// view holds in robot coordinates (obstacles, the object, the goal, the path) comes
// along, so the task runs in AR with the same buttons. Once placed, Measure (./measure.ts)
// takes lengths in the room for the home drawn in My home. Without AR the page says so
// and keeps the 3D view.

import {
  Matrix4,
  Mesh,
  MeshBasicMaterial,
  Quaternion,
  RingGeometry,
  Scene,
  Vector3,
  type Object3D,
} from "three";
import type { Viewer } from "../scene";
import type { Quat, Vec3 } from "../types";
import "./ar.css";
import { el } from "../ui/dom";
import { type HomeEdit, Measure, type MeasureState } from "./measure";

export type ArSessionState = "unsupported" | "available" | "active" | "placed";

export interface ArPlacement {
  /** The robot's base in the AR session's `local` reference space (y up, metres). */
  xyz: Vec3;
  /** Its orientation there (x, y, z, w): the robot's z axis along the space's y. */
  quat: Quat;
}

export interface ArState {
  session: ArSessionState;
  /** True while the reticle sits on a surface found by hit-test. */
  reticle: boolean;
  /** Planes the browser reports (plane detection); 0 where it is not offered. */
  planes: number;
  /** Where the robot stands, once placed; null before. */
  placement: ArPlacement | null;
  /** Why AR is unavailable or failed, or null. */
  error: string | null;
  /** The Measure mode (./measure.ts): its ends, aim, length and last message. */
  measure: MeasureState;
}

/** Robot coordinates (z up) to WebXR coordinates (y up): -90 degrees about x. */
const Z_UP_TO_Y_UP = new Matrix4().makeRotationX(-Math.PI / 2);
const RETICLE_COLOR = 0x386fd1;

export class ArView {
  private status: ArSessionState = "unsupported";
  private error: string | null = null;
  private session: XRSession | null = null;
  private hitSource: XRHitTestSource | null = null;
  private readonly overlayScene = new Scene();
  private readonly reticle: Mesh;
  private reticleSeen = false;
  private planes = 0;
  private placement: ArPlacement | null = null;
  /** Where the robot would stand if the user tapped now. */
  private pending: ArPlacement | null = null;
  /** The panel section: the app mounts it (Panel.mount). */
  readonly section: HTMLElement;
  private readonly button = el("button", { type: "button", id: "ar-enter" }, "View in AR");
  private readonly note = el("p", { class: "hint", id: "ar-status" }, "Checking for AR…");
  private readonly overlay = el("div", { class: "ar-overlay", id: "ar-overlay", hidden: "" });
  private readonly overlayText = el("p", { id: "ar-hint" });
  private readonly measure: Measure;

  /** `robotHolder()`: the group that places the robot in the 3D view (its spawn pose);
   * `editHome`: changes the home drawn in My home (measurements join it). */
  constructor(
    private readonly viewer: Viewer,
    private readonly robotHolder: () => Object3D | null,
    editHome: HomeEdit | null = null,
  ) {
    this.reticle = new Mesh(
      new RingGeometry(0.07, 0.09, 40).rotateX(-Math.PI / 2),
      new MeshBasicMaterial({ color: RETICLE_COLOR }),
    );
    this.reticle.name = "ar-reticle";
    this.reticle.matrixAutoUpdate = false;
    this.reticle.visible = false;
    this.overlayScene.add(this.reticle);
    this.measure = new Measure(
      () => this.placement,
      editHome,
      (text) => (this.overlayText.textContent = text),
    );
    this.overlayScene.add(this.measure.group);

    const exit = el("button", { type: "button", id: "ar-exit" }, "Leave AR");
    exit.addEventListener("click", () => void this.session?.end());
    // On a phone only this bar shows over the camera image: it carries the task's
    // buttons (task/panel.ts) so the task runs in AR.
    const taskButtons = [
      ["#set-robot", "Set Robot"],
      ["#move-robot", "Move Robot!"],
    ].map(([target, label]) => {
      const button = el("button", { type: "button", "data-ar-task": target }, label);
      button.addEventListener("click", () => document.querySelector<HTMLElement>(target)?.click());
      return button;
    });
    this.overlay.append(this.overlayText, ...taskButtons, this.measure.bar, exit);
    // A tap on the bar's buttons is not a tap on the room (no `select` from it).
    this.overlay.addEventListener("beforexrselect", (e) => e.preventDefault());
    document.body.append(this.overlay);
    this.section = el(
      "section",
      { class: "ar", id: "ar" },
      el("h2", {}, "Augmented reality"),
      this.note,
      this.button,
    );
    this.button.disabled = true;
    this.button.addEventListener("click", () => void this.enter());
  }

  /** Find out whether this browser can start an immersive-ar session with hit-test. */
  async check(): Promise<void> {
    const xr = navigator.xr;
    let supported = false;
    try {
      supported = !!xr && (await xr.isSessionSupported("immersive-ar"));
    } catch (err) {
      this.error = err instanceof Error ? err.message : String(err);
    }
    if (!supported) {
      this.error ??= xr
        ? "this browser has no immersive AR (WebXR immersive-ar)"
        : "this browser has no WebXR (needs HTTPS and an AR-capable phone or headset)";
      this.set("unsupported");
      this.note.textContent = `No AR here: ${this.error}. The 3D view stays as it is.`;
      return;
    }
    this.set("available");
    this.note.textContent =
      "Point the camera at the floor or a table; tap where the robot should stand.";
  }

  state(): ArState {
    return {
      session: this.status,
      reticle: this.reticleSeen,
      planes: this.planes,
      placement: this.placement,
      error: this.error,
      measure: this.measure.state(),
    };
  }

  /** Start the AR session: the view turns into the camera image with the robot over it. */
  async enter(): Promise<void> {
    if (this.status !== "available" || !navigator.xr) return;
    const renderer = this.viewer.renderer;
    try {
      const session = await navigator.xr.requestSession("immersive-ar", {
        requiredFeatures: ["hit-test"],
        optionalFeatures: ["plane-detection", "dom-overlay", "local-floor"],
        domOverlay: { root: this.overlay },
      } as XRSessionInit);
      this.session = session;
      renderer.xr.enabled = true;
      renderer.xr.setReferenceSpaceType("local");
      await renderer.xr.setSession(session);
      const viewerSpace = await session.requestReferenceSpace("viewer");
      this.hitSource = (await session.requestHitTestSource?.({ space: viewerSpace })) ?? null;
      if (!this.hitSource) throw new Error("the AR session offers no hit-test");
      session.addEventListener("select", () => (this.measure.active ? this.measure.tap() : this.place()));
      session.addEventListener("end", () => this.ended());
    } catch (err) {
      this.error = `could not start AR: ${err instanceof Error ? err.message : err}`;
      this.note.textContent = this.error;
      await this.session?.end().catch(() => undefined);
      this.ended();
      return;
    }
    this.error = null;
    this.placement = null;
    this.measure.offer(false);
    this.viewer.showSurroundings(false);
    this.viewer.scene.visible = false;
    this.overlay.hidden = false;
    for (const button of this.overlay.querySelectorAll<HTMLButtonElement>("[data-ar-task]")) {
      button.hidden = true;
    }
    this.overlayText.textContent = "Looking for the floor…";
    this.set("active");
    renderer.setAnimationLoop((_, frame) => this.frame(frame));
  }

  private frame(frame: XRFrame | undefined): void {
    const renderer = this.viewer.renderer;
    const space = renderer.xr.getReferenceSpace();
    if (frame && space && this.hitSource) {
      const hit = frame.getHitTestResults(this.hitSource)[0];
      const pose = hit?.getPose(space);
      this.reticleSeen = !!pose;
      this.reticle.visible = !!pose && (this.status === "active" || this.measure.aiming);
      if (pose) {
        this.reticle.matrix.fromArray(pose.transform.matrix);
        if (this.status === "active") {
          this.placeScene(this.reticle.matrix);
          this.overlayText.textContent = "Tap to place the robot here.";
        }
      }
      if (this.status === "placed") {
        const eye = new Vector3().setFromMatrixPosition(renderer.xr.getCamera().matrixWorld);
        this.measure.frame(pose ? this.reticle.matrix : null, eye);
      }
      const planes = (frame as XRFrame & { detectedPlanes?: Set<unknown> }).detectedPlanes;
      this.planes = planes ? planes.size : 0;
    }
    const camera = this.viewer.camera;
    renderer.render(this.viewer.scene, camera);
    renderer.autoClear = false;
    renderer.render(this.overlayScene, camera);
    renderer.autoClear = true;
  }

  /** Put the robot (and everything in robot coordinates) on `spot`, facing the viewer. */
  private placeScene(spot: Matrix4): void {
    const at = new Vector3().setFromMatrixPosition(spot);
    const eye = new Vector3().setFromMatrixPosition(this.viewer.camera.matrixWorld);
    const xr = this.viewer.renderer.xr;
    if (xr.isPresenting) eye.setFromMatrixPosition(xr.getCamera().matrixWorld);
    const toward = eye.sub(at);
    const yaw = Math.atan2(-toward.z, toward.x);
    const base = new Matrix4().makeTranslation(at.x, at.y, at.z);
    base.multiply(new Matrix4().makeRotationY(yaw)).multiply(Z_UP_TO_Y_UP);
    const holder = this.robotHolder();
    const spawn = holder ? holder.matrix.clone() : new Matrix4();
    const scene = this.viewer.scene;
    base.clone().multiply(spawn.invert()).decompose(scene.position, scene.quaternion, scene.scale);
    scene.updateMatrixWorld(true);
    scene.visible = true;
    const q = new Quaternion().setFromRotationMatrix(base);
    this.pending = { xyz: [at.x, at.y, at.z], quat: [q.x, q.y, q.z, q.w] };
  }

  /** The user tapped: the robot stays where the reticle is. */
  private place(): void {
    if (this.status !== "active" || !this.reticleSeen || !this.pending) return;
    this.placement = this.pending;
    this.reticle.visible = false;
    this.overlayText.textContent = "Placed. Set Robot, then Move Robot! Or Measure your room.";
    for (const button of this.overlay.querySelectorAll<HTMLButtonElement>("[data-ar-task]")) {
      button.hidden = !document.querySelector(button.dataset.arTask ?? "");
    }
    this.measure.offer(true);
    this.set("placed");
  }

  private ended(): void {
    const renderer = this.viewer.renderer;
    renderer.setAnimationLoop(null);
    renderer.xr.enabled = false;
    this.hitSource?.cancel();
    this.hitSource = null;
    this.session = null;
    this.reticleSeen = false;
    this.reticle.visible = false;
    this.measure.offer(false);
    const scene = this.viewer.scene;
    scene.position.set(0, 0, 0);
    scene.quaternion.identity();
    scene.scale.set(1, 1, 1);
    scene.visible = true;
    scene.updateMatrixWorld(true);
    this.overlay.hidden = true;
    this.viewer.showSurroundings(true);
    if (this.status !== "unsupported") this.set("available");
  }

  private set(status: ArSessionState): void {
    this.status = status;
    this.button.disabled = status !== "available";
    this.button.textContent = status === "active" || status === "placed" ? "In AR" : "View in AR";
  }
}

/** A test-only WebXR device, when the page URL says ?xr=emulate (see ./emulate.ts). */
export async function installEmulatorIfAsked(): Promise<void> {
  if (new URLSearchParams(location.search).get("xr") !== "emulate") return;
  const { installEmulatedAr } = await import("./emulate");
  installEmulatedAr();
}
