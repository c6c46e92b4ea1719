// The 3D view: renderer, camera, orbit controls, lights with shadows, and two slots,
// one for the world and one for the robot. It renders only when something changed, so
// an idle page costs no CPU.
//
// Frames follow the robot convention (ROS, URDF, RDTF): z is up, lengths in metres.

import {
  Box3,
  Color,
  DirectionalLight,
  Group,
  HemisphereLight,
  Mesh,
  NeutralToneMapping,
  Object3D,
  PCFShadowMap,
  PerspectiveCamera,
  PlaneGeometry,
  Scene,
  ShadowMaterial,
  Sphere,
  Vector3,
  WebGLRenderer,
  GridHelper,
  type Material,
} from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";

Object3D.DEFAULT_UP.set(0, 0, 1);

const BACKGROUND = 0xeef1f5;
/** Where the camera looks from, relative to what it frames: in front, to the right, above. */
const VIEW_DIRECTION = new Vector3(1.0, -1.25, 0.8).normalize();
/** Where the sun shines from: high, in front of the robot and to its right. */
const SUN_DIRECTION = new Vector3(0.5, -0.8, 1.6).normalize();

export class Viewer {
  readonly renderer: WebGLRenderer;
  readonly scene = new Scene();
  readonly camera = new PerspectiveCamera(40, 1, 0.01, 200);
  readonly controls: OrbitControls;
  private readonly sun = new DirectionalLight(0xffffff, 2.0);
  private readonly ground = new Group();
  private readonly worldSlot = new Group();
  private readonly robotSlot = new Group();
  private frameRequested = false;
  private waiting: Array<() => void> = [];

  constructor(container: HTMLElement) {
    this.renderer = new WebGLRenderer({ antialias: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.renderer.shadowMap.enabled = true;
    this.renderer.shadowMap.type = PCFShadowMap;
    this.renderer.toneMapping = NeutralToneMapping;
    container.appendChild(this.renderer.domElement);

    this.scene.background = new Color(BACKGROUND);

    const sky = new HemisphereLight(0xffffff, 0xcfc8bd, 2.4);
    sky.position.set(0, 0, 1);
    this.sun.castShadow = true;
    this.sun.shadow.mapSize.set(2048, 2048);
    this.sun.shadow.bias = -0.0004;
    this.sun.shadow.normalBias = 0.02;
    this.scene.add(sky, this.sun, this.sun.target, this.ground, this.worldSlot, this.robotSlot);
    this.buildGround();

    this.camera.position.set(1.2, -1.5, 1.0);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = true;
    this.controls.dampingFactor = 0.12;
    this.controls.addEventListener("change", () => this.requestRender());

    // the canvas, not the container: a card docked in the container (the hand's path)
    // takes part of its height
    new ResizeObserver(() => this.resize()).observe(this.renderer.domElement);
    this.resize();
  }

  /** Put `world` in the scene (replacing the last one); null shows a plain ground. */
  setWorld(world: Object3D | null): void {
    replaceChildren(this.worldSlot, world);
    this.ground.visible = world === null;
    this.fitShadows();
    this.requestRender();
  }

  /** Put `robot` in the scene (replacing the last one). */
  setRobot(robot: Object3D | null): void {
    replaceChildren(this.robotSlot, robot);
    this.fitShadows();
    this.requestRender();
  }

  /** Show or hide the world, the plain ground and the background (AR shows the real
   * room in their place). */
  showSurroundings(visible: boolean): void {
    this.worldSlot.visible = visible;
    this.ground.visible = visible && this.worldSlot.children.length === 0;
    this.scene.background = visible ? new Color(BACKGROUND) : null;
    this.requestRender();
  }

  /** Point the camera at `object`, close enough to fill the view. In a room the camera
   * stands on the room's side of the object, so walls behind it do not block the view. */
  frame(object: Object3D): void {
    const sphere = new Box3().setFromObject(object).getBoundingSphere(new Sphere());
    const radius = Math.max(sphere.radius, 0.15);
    const fov = (this.camera.fov * Math.PI) / 180;
    const distance = (radius / Math.sin(fov / 2)) * 1.3;
    this.controls.target.copy(sphere.center);
    const direction = this.viewDirection(sphere.center);
    this.camera.position.copy(sphere.center).addScaledVector(direction, distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 100;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.requestRender();
  }

  /** Resolves once the next frame has been drawn. */
  rendered(): Promise<void> {
    if (this.empty()) return Promise.resolve();
    return new Promise((resolve) => {
      this.waiting.push(resolve);
      this.requestRender();
    });
  }

  /** Draw a new frame soon (once, however often this is called before it). Nothing is
   * drawn before a world or robot arrives: the empty view is the page's background. */
  requestRender(): void {
    if (this.frameRequested) return;
    if (this.empty()) return;
    this.frameRequested = true;
    requestAnimationFrame(() => {
      this.frameRequested = false;
      // With damping the controls keep moving for a few frames after the pointer stops.
      if (this.controls.update()) this.requestRender();
      this.renderer.render(this.scene, this.camera);
      const waiting = this.waiting;
      this.waiting = [];
      for (const resolve of waiting) resolve();
    });
  }

  /** From `point` towards the camera: towards the world's middle if `point` is far from
   * it (a robot in a room), else from the front right, above. */
  private viewDirection(point: Vector3): Vector3 {
    const world = new Box3().setFromObject(this.worldSlot);
    if (world.isEmpty()) return VIEW_DIRECTION.clone();
    const inward = world.getCenter(new Vector3()).sub(point).setZ(0);
    if (inward.length() < 1.0) return VIEW_DIRECTION.clone();
    inward.normalize();
    return new Vector3(inward.x, inward.y, 0.75).normalize();
  }

  private empty(): boolean {
    return this.worldSlot.children.length === 0 && this.robotSlot.children.length === 0;
  }

  private resize(): void {
    const { clientWidth: w, clientHeight: h } = this.renderer.domElement;
    if (w === 0 || h === 0) return;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  /** A shadow-catching floor with a faint grid, shown when there is no world. */
  private buildGround(): void {
    const plane = new Mesh(new PlaneGeometry(20, 20), new ShadowMaterial({ opacity: 0.18 }));
    plane.receiveShadow = true;
    const grid = new GridHelper(10, 40, 0xc3c9d1, 0xdde1e7);
    grid.rotation.x = Math.PI / 2;
    grid.position.z = -0.0005;
    this.ground.add(plane, grid);
  }

  /** Aim the sun's shadow camera at everything in the slots, tightly, for crisp shadows. */
  private fitShadows(): void {
    const box = new Box3().expandByObject(this.worldSlot).expandByObject(this.robotSlot);
    if (box.isEmpty()) return;
    const sphere = box.getBoundingSphere(new Sphere());
    const r = Math.max(sphere.radius, 0.5);
    this.sun.target.position.copy(sphere.center);
    this.sun.position.copy(sphere.center).addScaledVector(SUN_DIRECTION, 2 * r);
    const cam = this.sun.shadow.camera;
    cam.left = -r;
    cam.right = r;
    cam.top = r;
    cam.bottom = -r;
    cam.near = 0.01;
    cam.far = 4 * r;
    cam.updateProjectionMatrix();
    this.sun.target.updateMatrixWorld();
  }
}

/** Let every mesh under `object` cast and receive shadows. */
export function enableShadows(object: Object3D): void {
  object.traverse((o) => {
    if (o instanceof Mesh) {
      o.castShadow = true;
      o.receiveShadow = true;
    }
  });
}

function replaceChildren(slot: Group, object: Object3D | null): void {
  for (const old of [...slot.children]) {
    slot.remove(old);
    dispose(old);
  }
  if (object) slot.add(object);
}

/** Free the GPU memory of meshes that leave the scene. */
function dispose(object: Object3D): void {
  object.traverse((o) => {
    if (o instanceof Mesh) {
      o.geometry.dispose();
      const materials: Material[] = Array.isArray(o.material) ? o.material : [o.material];
      for (const m of materials) m.dispose();
    }
  });
}
