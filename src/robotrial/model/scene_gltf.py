"""A World as glTF 2.0 binary for the browser: floor, walls, obstacles, objects, lights.

Layer 1 (descriptions). `write_world_glb(world)` gives a `.glb` that three.js (or any
glTF viewer) draws as the room. Node names match the MJCF the simulator uses, so the
page can pair a drawn body with a simulated one:

- `floor`: a rectangle at the floor height;
- `wall/NAME`, `obstacle/NAME` (furniture too), `object/NAME` (movable objects):
  one node per body placed at its pose, holding its mesh and a PBR material from its
  rgba; the node's `extras` give `kind`, `mass` and the shape's parameters;
- `light/NAME`: a `KHR_lights_punctual` light (directional lights shine along the
  node's -z, which the writer turns to the light's direction).

Physics as in RDTF: static colliders (`KHR_physics_rigid_bodies` + `KHR_implicit_shapes`)
on child nodes `NODE/collider`, and a motion with the mass on each movable object.
Coordinates are the world's (metres, z up), like RDTF. docs/rdtf.md describes it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pygltflib
from scipy.spatial.transform import Rotation

from robotrial.geometry import Box, Cylinder, Mesh, Pose, Shape, Sphere
from robotrial.model.gltf import (
    PHYSICS_EXTENSION,
    SHAPES_EXTENSION,
    Y_TO_Z,
    GltfBuilder,
    primitive_triangles,
)
from robotrial.model.meshes import load_mesh
from robotrial.model.robot import ModelError
from robotrial.model.world import Light, Obstacle, World

LIGHTS_EXTENSION = "KHR_lights_punctual"


def _shape_extras(shape: Shape) -> dict[str, Any]:
    if isinstance(shape, Box):
        return {"shape": "box", "size": list(shape.size)}
    if isinstance(shape, Cylinder):
        return {"shape": "cylinder", "radius": shape.radius, "length": shape.length}
    if isinstance(shape, Sphere):
        return {"shape": "sphere", "radius": shape.radius}
    if isinstance(shape, Mesh):
        return {"shape": "mesh", "file": shape.filename, "scale": list(shape.scale)}
    raise ModelError(f"unknown shape {shape!r}")


def _light_rotation(direction) -> Pose:
    """The rotation that turns a node's -z onto `direction`."""
    d = np.asarray(direction, dtype=float)
    n = float(np.linalg.norm(d))
    if not n > 0:
        raise ModelError(f"light direction {tuple(d)} has no length")
    rot, _ = Rotation.align_vectors([d / n], [[0.0, 0.0, -1.0]])
    return Pose((0.0, 0.0, 0.0), rot.as_quat())


class _WorldWriter:
    def __init__(self, world: World) -> None:
        self.world = world
        self.b = GltfBuilder()
        self.shapes: list[dict] = []
        self.accessors: dict[tuple, tuple[int, int, int] | None] = {}
        self.scene_nodes: list[int] = []
        self.physics = False

    def _collider(self, name: str, shape: Shape, mesh: int | None) -> int | None:
        """A child node `NAME/collider` with the body's collision shape, or None."""
        pose = Pose()
        if isinstance(shape, Box):
            spec = {"type": "box", "box": {"size": list(shape.size)}}
        elif isinstance(shape, Sphere):
            spec = {"type": "sphere", "sphere": {"radius": shape.radius}}
        elif isinstance(shape, Cylinder):
            r = shape.radius
            spec = {
                "type": "cylinder",
                "cylinder": {"height": shape.length, "radiusTop": r, "radiusBottom": r},
            }
            pose = Y_TO_Z
        else:
            spec = None
        if spec is not None:
            self.shapes.append(spec)
            geometry: dict[str, Any] = {"shape": len(self.shapes) - 1}
        elif mesh is not None:
            holder = self.b.node(f"{name}/collider/mesh", mesh=mesh)
            geometry = {"node": holder, "convexHull": False}
        else:
            return None
        self.physics = True
        ext = {PHYSICS_EXTENSION: {"collider": {"geometry": geometry}}}
        return self.b.node(f"{name}/collider", pose, extensions=ext)

    def _mesh(self, name: str, shape: Shape, rgba) -> int | None:
        """The glTF mesh of a body; the same shape's triangles are stored once."""
        material = self.b.material(f"rgba({', '.join(f'{c:g}' for c in rgba)})", rgba)
        key: tuple = (
            ("mesh", shape.filename, id(shape.data)) if isinstance(shape, Mesh) else (shape,)
        )
        if key not in self.accessors:
            if isinstance(shape, Mesh):
                data = load_mesh(shape, scaled=False)
                self.accessors[key] = self.b.triangles(data.vertices, data.faces)
            else:
                vertices, normals, faces = primitive_triangles(shape)
                self.accessors[key] = self.b.triangles(vertices, faces, normals)
        accessors = self.accessors[key]
        return None if accessors is None else self.b.mesh(name, accessors, material)

    def body(self, prefix: str, body: Obstacle) -> int:
        name = f"{prefix}/{body.name}"
        shape = body.geometry
        mesh = self._mesh(name, shape, body.rgba)
        fields: dict[str, Any] = {}
        if mesh is not None:
            fields["mesh"] = mesh
        if isinstance(shape, Mesh) and shape.scale != (1.0, 1.0, 1.0):
            fields["scale"] = list(shape.scale)
        collider = self._collider(name, shape, mesh)
        if collider is not None:
            fields["children"] = [collider]
        if body.mass > 0:
            self.physics = True
            fields["extensions"] = {PHYSICS_EXTENSION: {"motion": {"mass": body.mass}}}
        fields["extras"] = {
            "kind": body.kind,
            "mass": body.mass,
            "rgba": list(body.rgba),
            **_shape_extras(shape),
        }
        return self.b.node(name, body.pose, **fields)

    def floor(self) -> int:
        fl = self.world.floor
        (sx, sy), (cx, cy) = fl.size, fl.center
        hx, hy = sx / 2, sy / 2
        vertices = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], float)
        normals = np.tile([0.0, 0.0, 1.0], (4, 1))
        faces = np.array([[0, 1, 2], [0, 2, 3]])
        material = self.b.material("floor", fl.rgba)
        accessors = self.b.triangles(vertices, faces, normals)
        assert accessors is not None
        mesh = self.b.mesh("floor", accessors, material)
        self.shapes.append({"type": "plane", "plane": {"sizeX": sx, "sizeZ": sy}})
        self.physics = True
        collider = self.b.node(
            "floor/collider",
            Y_TO_Z,
            extensions={
                PHYSICS_EXTENSION: {"collider": {"geometry": {"shape": len(self.shapes) - 1}}}
            },
        )
        return self.b.node(
            "floor",
            Pose((cx, cy, fl.height)),
            mesh=mesh,
            children=[collider],
            extras={"kind": "floor", "friction": fl.friction, "size": [sx, sy]},
        )

    def light(self, index: int, light: Light) -> int:
        if light.type not in ("directional", "point"):
            raise ModelError(
                f"world {self.world.name!r}: light {light.name!r} has type {light.type!r}; "
                "expected directional or point"
            )
        pose = Pose(light.pose.xyz, light.pose.quat)
        if light.type == "directional":
            pose = Pose(light.pose.xyz, _light_rotation(light.direction).quat)
        return self.b.node(
            f"light/{light.name}", pose, extensions={LIGHTS_EXTENSION: {"light": index}}
        )

    def write(self) -> bytes:
        w = self.world
        nodes = [self.floor()]
        nodes += [self.body("wall", b) for b in w.walls]
        nodes += [self.body("obstacle", b) for b in w.obstacles]
        nodes += [self.body("object", b) for b in w.objects]
        lights = [
            {
                "name": li.name,
                "type": li.type,
                "color": [min(max(float(c), 0.0), 1.0) for c in li.color],
                "intensity": max(float(li.intensity), 0.0),
            }
            for li in w.lights
        ]
        nodes += [self.light(i, li) for i, li in enumerate(w.lights)]
        self.b.gltf.scenes = [pygltflib.Scene(name=w.name, nodes=nodes)]
        self.b.gltf.scene = 0
        ext: dict[str, Any] = {}
        used = []
        if lights:
            ext[LIGHTS_EXTENSION] = {"lights": lights}
            used.append(LIGHTS_EXTENSION)
        if self.physics:
            used.append(PHYSICS_EXTENSION)
        if self.shapes:
            ext[SHAPES_EXTENSION] = {"shapes": self.shapes}
            used.append(SHAPES_EXTENSION)
        if ext:
            self.b.gltf.extensions = ext
        self.b.gltf.extras = {
            "world": {
                "name": w.name,
                "description": w.description,
                "spawns": {
                    k: {"xyz": list(p.xyz), "quat": list(p.quat)} for k, p in w.spawns.items()
                },
                "interior": None if w.interior is None else [list(c) for c in w.interior],
            }
        }
        return self.b.finish(sorted(used))


def write_world_glb(world: World, path: str | Path | None = None) -> bytes:
    """The glTF binary (.glb) of `world` for the browser; also written to `path` if given."""
    data = _WorldWriter(world).write()
    if path is not None:
        Path(path).write_bytes(data)
    return data
