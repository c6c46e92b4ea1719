// Test-only: an emulated AR device (iwer) with a tiny synthetic room, loaded when the
// page URL says ?xr=emulate. The room is a floor at height 0 and a counter top 0.9 m
// high (x from 1.0 to 2.2 m, z from -2.4 to -1.8 m, its front edge at z = -1.8 m); both
// answer hit-tests and show up as detected planes. The device stands 1.6 m above the
// floor looking 45 degrees down, so the centre of its view meets the floor about 1.6 m
// ahead (the counter is off to the side of that ray).
// `window.robotrialXR` is the device, for tests to press its trigger (a `select`).

import {
  metaQuest3,
  NativePlane,
  XRDevice,
  XRRigidTransform,
  XRSemanticLabels,
} from "iwer";

type SEMConstructor = Parameters<XRDevice["installSEM"]>[0];

declare global {
  interface Window {
    robotrialXR?: XRDevice;
  }
}

type Mat4 = Float32Array | number[];

/** The counter top: its height and its extent along x and z (m, global space). */
export const COUNTER = { height: 0.9, x: [1.0, 2.2], z: [-2.4, -1.8] } as const;

/** A flat floor at y = 0 and a counter top, in the device's global space. */
class FloorEnvironment {
  readonly version = "robotrial-floor";
  planesVisible = false;
  boundingBoxesVisible = false;
  meshesVisible = false;
  readonly trackedPlanes = new Set<NativePlane>();
  readonly trackedMeshes = new Set<never>();
  private readonly canvas = document.createElement("canvas");

  constructor() {
    const half = 4;
    const corners = [
      [-half, -half],
      [half, -half],
      [half, half],
      [-half, half],
    ].map(([x, z]) => new DOMPointReadOnly(x, 0, z, 1));
    this.trackedPlanes.add(
      new NativePlane(new XRRigidTransform(), corners, XRSemanticLabels.Floor),
    );
    const [x0, x1] = COUNTER.x;
    const [z0, z1] = COUNTER.z;
    const top = [
      [x0, z0],
      [x1, z0],
      [x1, z1],
      [x0, z1],
    ].map(([x, z]) => new DOMPointReadOnly(x, COUNTER.height, z, 1));
    this.trackedPlanes.add(
      new NativePlane(new XRRigidTransform(), top, XRSemanticLabels.Table),
    );
  }

  get environmentCanvas(): HTMLCanvasElement {
    return this.canvas;
  }

  render(): void {}
  loadEnvironment(): void {}
  loadDefaultEnvironment(): void {}
  deleteAll(): void {}

  computeDepthBuffer(): null {
    return null;
  }

  /** Where the ray (origin at the matrix's translation, along its -z axis) first meets
   * the counter top or the floor: one pose with the surface's normal as its y axis, or
   * none (the ray points level or up). */
  computeHitTestResults(ray: Mat4): Mat4[] {
    const [ox, oy, oz] = [ray[12], ray[13], ray[14]];
    const [dx, dy, dz] = [-ray[8], -ray[9], -ray[10]];
    if (dy > -1e-6) return [];
    const at = (height: number): [number, number] => {
      const t = (height - oy) / dy;
      return [ox + t * dx, oz + t * dz];
    };
    const [cx, cz] = at(COUNTER.height);
    const onCounter =
      oy > COUNTER.height &&
      cx >= COUNTER.x[0] &&
      cx <= COUNTER.x[1] &&
      cz >= COUNTER.z[0] &&
      cz <= COUNTER.z[1];
    const height = onCounter ? COUNTER.height : 0;
    const [x, z] = onCounter ? [cx, cz] : at(0);
    const hit = new Float32Array(16);
    hit[0] = hit[5] = hit[10] = hit[15] = 1;
    hit[12] = x;
    hit[13] = height;
    hit[14] = z;
    return [hit];
  }
}

export function installEmulatedAr(): void {
  const device = new XRDevice(metaQuest3);
  device.installRuntime({ forceInstall: true });
  device.installSEM(FloorEnvironment as unknown as SEMConstructor);
  const pitch = -Math.PI / 4;
  device.quaternion.set(Math.sin(pitch / 2), 0, 0, Math.cos(pitch / 2));
  window.robotrialXR = device;
}
