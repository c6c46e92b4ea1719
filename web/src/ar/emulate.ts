// Test-only: an emulated AR device (iwer) with a tiny synthetic room, loaded when the
// page URL says ?xr=emulate. The room is a floor at height 0 that answers hit-tests
// and shows up as one detected plane. The device stands 1.6 m above it looking 45
// degrees down, so the centre of its view meets the floor about 1.6 m ahead.
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

/** A flat floor at y = 0 in the device's global space. */
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

  /** Where the ray (origin at the matrix's translation, along its -z axis) meets the
   * floor: one pose with the floor's normal as its y axis, or none. */
  computeHitTestResults(ray: Mat4): Mat4[] {
    const [ox, oy, oz] = [ray[12], ray[13], ray[14]];
    const [dx, dy, dz] = [-ray[8], -ray[9], -ray[10]];
    if (dy > -1e-6) return [];
    const t = -oy / dy;
    const hit = new Float32Array(16);
    hit[0] = hit[5] = hit[10] = hit[15] = 1;
    hit[12] = ox + t * dx;
    hit[13] = 0;
    hit[14] = oz + t * dz;
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
