// Small value types shared across the client: three-vectors and quaternions as plain
// arrays, the way JSON, RDTF and the physics hand them over.

/** x, y, z: a position or a size (m), or a direction. */
export type Vec3 = [number, number, number];
/** x, y, z, w: a rotation as a unit quaternion. */
export type Quat = [number, number, number, number];
