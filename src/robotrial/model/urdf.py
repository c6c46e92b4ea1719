"""URDF and xacro in: a description file becomes a RobotModel.

Layer 1. xacro files are expanded first (model/xacro.py), then the XML is parsed with
lxml so every error can name the file, the element and its line. Every URDF field that
RobotModel holds is mapped, plus the `<robotrial>` element (tcp, groups, gripper,
drive, sensors, planner spheres; see docs/urdf.md). A file without that element (any
ROS robot) gets its tool link, arm group and gripper from its tree (model/anatomy.py).

Real-world files are messy. What is safe to fix is fixed, recorded in
`RobotModel.repairs` as a sentence, and announced with `warnings.warn` (category
`URDFRepairWarning`); what is not is refused with a ModelError.
"""

from __future__ import annotations

import math
import re
import sys
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from lxml import etree

from robotrial.geometry import Box, Cylinder, Mesh, Pose, Shape, Sphere, transform_points
from robotrial.model.anatomy import completed
from robotrial.model.meshes import mesh_bounds, mesh_format_supported
from robotrial.model.packages import PackageResolver, ResourceNotFound, ResourceRefused
from robotrial.model.robot import (
    JOINT_TYPES,
    SENSOR_TYPES,
    Collision,
    CollisionSphere,
    Inertial,
    Joint,
    JointDynamics,
    JointLimit,
    Link,
    Material,
    Mimic,
    ModelError,
    RobotModel,
    Sensor,
    Visual,
)
from robotrial.model.xacro import (
    XACRO_NS,
    XACRO_SUFFIXES,
    default_optenv,
    expand_xacro,
    expand_xacro_text,
)

DEFAULT_RGBA = (0.7, 0.7, 0.7, 1.0)
# density used to give a mass to a moving link that has none: a tenth of water's
REPAIR_DENSITY = 100.0  # kg/m^3
REPAIR_MASS_MIN = 0.001  # kg
REPAIR_MASS_MAX = 1.0  # kg
REPAIR_MIN_EXTENT = 0.01  # m, the smallest bounding box side used for a repair inertia
INERTIA_FLOOR = 1e-12  # kg m^2, the smallest principal moment kept
SHAPE_MIN = 1e-4  # m, what a zero box side / radius / length is repaired to


class URDFRepairWarning(UserWarning):
    """The loader changed something in a description to make it usable."""


def _outside_this_module() -> int:
    """The `stacklevel` that points a warning at the code that called the loader."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename == __file__:
        frame, level = frame.f_back, level + 1
    return level


# --- public entry points ----------------------------------------------------------------


def load_urdf(
    path: str | Path,
    package_paths: Sequence[str | Path] = (),
    xacro_args: Mapping[str, str] | None = None,
    confined: Path | None = None,
) -> RobotModel:
    """A RobotModel from a `.urdf` file or a `.xacro` / `.urdf.xacro` file.

    `package_paths` are searched first for `package://` URIs (then ROS_PACKAGE_PATH and
    the folders above the file); `xacro_args` are the `name:=value` arguments of xacro.
    `confined`: the folder the description and every file it names must stay in (an
    upload: see model/xacro.py and model/packages.py).
    """
    p = Path(path)
    if not p.is_file():
        raise ModelError(f"{p}: {'not a file' if p.exists() else 'no such file'}")
    if p.suffix.lower() in XACRO_SUFFIXES:
        text = expand_xacro(p, package_paths, xacro_args, confined)
        return urdf_from_string(
            text, str(p), p.parent, package_paths, expanded_from_xacro=True, confined=confined
        )
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise ModelError(f"{p}: cannot read: {exc.strerror or exc}") from exc
    return urdf_from_string(data, str(p), p.parent, package_paths, confined=confined)


def description_text(robot: RobotModel) -> str:
    """The URDF text of a robot loaded from a file (xacro expanded), as ROS's
    `robot_description` parameter holds it: what the file says, URIs unchanged.

    ModelError when the robot did not come from a readable file (built in code, or
    from an RDTF whose source is no longer on disk).
    """
    p = Path(robot.source) if robot.source else None
    if p is None or not p.is_file():
        raise ModelError(f"robot {robot.name!r}: no URDF file to describe it ({robot.source!r})")
    if p.suffix.lower() in XACRO_SUFFIXES:
        return expand_xacro(p)
    if p.suffix.lower() != ".urdf":
        raise ModelError(f"{p}: a robot description is a .urdf or .xacro file")
    try:
        return p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelError(f"{p}: cannot read: {exc}") from exc


def urdf_from_string(
    text: str | bytes,
    source: str = "<string>",
    base_dir: str | Path | None = None,
    package_paths: Sequence[str | Path] = (),
    expanded_from_xacro: bool = False,
    confined: Path | None = None,
) -> RobotModel:
    """A RobotModel from URDF text; `source` names it in messages, `base_dir` anchors
    relative paths and the package search (default: the folder of `source` if it is a
    file, else the current folder)."""
    if base_dir is None:
        sp = Path(source)
        base_dir = sp.parent if sp.is_file() else Path.cwd()
    slips: list[str] = []
    root = _parse_xml(text, source, slips)
    leftovers: list[str] = []
    raw_text = text if isinstance(text, str) else text.decode("utf-8", "replace")
    if not expanded_from_xacro and not _needs_xacro(root) and "$(optenv" in raw_text:
        text, leftovers = default_optenv(raw_text)
        root = _parse_xml(text.encode("utf-8"), source, [])
    if not expanded_from_xacro and _needs_xacro(root):
        raw = text if isinstance(text, bytes) else text.encode("utf-8")
        expanded = expand_xacro_text(raw, source, Path(base_dir), package_paths, confined)
        reader = _Reader(source, Path(base_dir), package_paths, True, confined)
        reader.repair(f"{source} uses xacro macros or properties; it was expanded with xacro")
        return reader.read(_parse_xml(expanded, source))
    reader = _Reader(source, Path(base_dir), package_paths, expanded_from_xacro, confined)
    for slip in slips:
        reader.repair(slip)
    for name in leftovers:
        reader.repair(f"{source}: $(optenv {name} ...) was never expanded; its default is used")
    return reader.read(root)


# --- xacro markup ----------------------------------------------------------------------


def _needs_xacro(root: etree._Element) -> bool:
    """Whether a plain URDF still holds xacro elements (an unexpanded file)."""
    for el in root.iter():
        tag = el.tag
        if isinstance(tag, str) and (tag.startswith(f"{{{XACRO_NS}}}") or tag.startswith("xacro:")):
            return True
    return False


# --- XML helpers -------------------------------------------------------------------------


_XML_DECL = re.compile(rb"<\?xml[^>]*?version\s*=\s*[\"']([^\"']*)[\"']")


def _tolerated(data: bytes) -> tuple[bytes, list[str]]:
    """`data` with the XML slips ROS's parser lets pass made good, and what was done:
    text before the XML declaration, an XML version other than 1.0/1.1, anything after
    the closing </robot>."""
    done = []
    start = data.find(b"<?xml")
    if start > 0 and not data[:start].strip(b" \t\r\n\xef\xbb\xbf"):
        data = data[start:]
        done.append("blank lines before the XML declaration removed")
    m = _XML_DECL.match(data)
    if m and m.group(1) not in (b"1.0", b"1.1"):
        data = data[: m.start(1)] + b"1.0" + data[m.end(1) :]
        done.append(f"XML version {m.group(1).decode(errors='replace')!r} read as 1.0")
    end = data.rfind(b"</robot>")
    if end >= 0 and data[end + 8 :].strip(b" \t\r\n"):
        data = data[: end + 8] + b"\n"
        done.append("content after the closing </robot> ignored")
    return data, done


def _parse_xml(text: str | bytes, source: str, repairs: list[str] | None = None) -> etree._Element:
    """The root <robot> element. With `repairs`, XML slips that ROS's parser accepts are
    made good (see _tolerated) and described there; otherwise they are errors."""
    data = text.encode("utf-8") if isinstance(text, str) else text
    # made good before parsing: libxml2 does not always stop at bytes after the root
    # (a NUL may end its input), so waiting for its error would miss some
    fixed, done = _tolerated(data) if repairs is not None else (data, [])
    parser = etree.XMLParser(remove_comments=True, huge_tree=True, resolve_entities=False)
    try:
        root = etree.fromstring(fixed, parser)
    except etree.XMLSyntaxError as exc:
        line = exc.lineno if exc.lineno else "?"
        raise ModelError(f"{source}:{line}: not well-formed XML: {exc.msg}") from exc
    if repairs is not None:
        repairs.extend(f"{source}: {d} (as ROS's URDF parser does)" for d in done)
    if root is None or etree.QName(root).localname != "robot":
        tag = etree.QName(root).localname if root is not None else "nothing"
        raise ModelError(
            f"{source}:{getattr(root, 'sourceline', '?')}: the root element is <{tag}>, "
            "expected <robot> (is this a URDF file?)"
        )
    return root


def _tag(el: etree._Element) -> str:
    return etree.QName(el).localname if isinstance(el.tag, str) else ""


def _children(el: etree._Element, name: str) -> list[etree._Element]:
    return [c for c in el if _tag(c) == name]


def _child(el: etree._Element, name: str) -> etree._Element | None:
    found = _children(el, name)
    return found[0] if found else None


_NUM_SPLIT = re.compile(r"[\s,]+")


class _Reader:
    """Reads one <robot> element; collects repairs; raises ModelError with locations."""

    def __init__(
        self,
        source: str,
        base_dir: Path,
        package_paths: Sequence[str | Path],
        expanded: bool,
        confined: Path | None = None,
    ) -> None:
        self.source = source
        self.resolver = PackageResolver.create(base_dir, package_paths, confined=confined)
        self.expanded = expanded
        self.repairs: list[str] = []
        self.materials: dict[str, Material] = {}
        self.material_lines: dict[str, int] = {}
        self.zero_mass: set[str] = set()

    # --- messages ---------------------------------------------------------------------

    def where(self, el: etree._Element | None) -> str:
        line = getattr(el, "sourceline", None) or "?"
        suffix = " of the xacro expansion" if self.expanded else ""
        return f"{self.source}:{line}{suffix}"

    def describe(self, el: etree._Element) -> str:
        name = el.get("name")
        return f"<{_tag(el)} name={name!r}>" if name is not None else f"<{_tag(el)}>"

    def error(self, el: etree._Element | None, msg: str) -> ModelError:
        what = f" {self.describe(el)}" if el is not None else ""
        return ModelError(f"{self.where(el)}:{what}: {msg}")

    def repair(self, msg: str) -> None:
        self.repairs.append(msg)
        warnings.warn(msg, URDFRepairWarning, stacklevel=_outside_this_module())

    # --- attribute parsing ------------------------------------------------------------

    def floats(self, el: etree._Element, attr: str, n: int, default=None) -> tuple[float, ...]:
        raw = el.get(attr)
        if raw is None:
            if default is None:
                raise self.error(el, f"missing attribute {attr!r}")
            return tuple(float(x) for x in default)
        parts = [p for p in _NUM_SPLIT.split(raw.strip()) if p]
        try:
            vals = tuple(float(p) for p in parts)
        except ValueError:
            raise self.error(el, f"{attr}={raw!r} is not {n} number(s)") from None
        if len(vals) != n:
            raise self.error(el, f"{attr}={raw!r} has {len(vals)} number(s), expected {n}")
        if not all(math.isfinite(v) for v in vals):
            raise self.error(el, f"{attr}={raw!r} is not finite")
        return vals

    def number(self, el: etree._Element, attr: str, default: float | None = None) -> float:
        return self.floats(el, attr, 1, None if default is None else (default,))[0]

    def name(self, el: etree._Element, what: str) -> str:
        n = el.get("name")
        if n is None or not n.strip():
            raise self.error(el, f"{what} has no name attribute")
        return n.strip()

    def origin(self, el: etree._Element) -> Pose:
        o = _child(el, "origin")
        if o is None:
            return Pose()
        xyz = self.floats(o, "xyz", 3, (0.0, 0.0, 0.0))
        rpy = self.floats(o, "rpy", 3, (0.0, 0.0, 0.0))
        return Pose.from_xyz_rpy(xyz, rpy)

    # --- the robot --------------------------------------------------------------------

    def read(self, root: etree._Element) -> RobotModel:
        name = (root.get("name") or "").strip()
        if not name:
            name = Path(self.source).name.split(".")[0] or "robot"
            self.repair(f"<robot> has no name; named it {name!r} after the file")
        for m in _children(root, "material"):
            self.name(m, "a top-level <material>")
            mat = self.material(m, owner="robot")
            first = self.materials.get(mat.name)
            if first is None:
                self.materials[mat.name] = mat
                self.material_lines[mat.name] = m.sourceline or 0
            elif first != mat:
                self.repair(
                    f"material {mat.name!r} (line {m.sourceline}) is defined again with "
                    f"other values; the first definition (line "
                    f"{self.material_lines[mat.name]}) is kept"
                )
        link_els = _children(root, "link")
        if not link_els:
            hint = (
                " (a xacro file that only defines macros describes no robot by itself; "
                "load the file that calls them)"
                if self.expanded
                else ""
            )
            raise self.error(root, f"the robot has no <link>{hint}")
        link_lines: dict[str, etree._Element] = {}
        for el in link_els:
            ln = self.name(el, "<link>")
            if ln in link_lines:
                raise self.error(
                    el, f"link {ln!r} is defined twice (first at line {link_lines[ln].sourceline})"
                )
            link_lines[ln] = el
        joints = [self.joint(el, link_lines) for el in _children(root, "joint")]
        joint_els = {j.name: el for j, el in zip(joints, _children(root, "joint"), strict=True)}
        self.check_tree(root, link_lines, joints, joint_els)
        links = self.add_missing_masses([self.link(el) for el in link_els], joints)
        joints = self.check_mimics(joints, joint_els)
        ext = self.robotrial(root, {lk.name for lk in links}, {j.name for j in joints})
        for prefix, folder in self.resolver.remaps.items():
            shown = self.resolver.shown(folder)
            where = "at its top level" if shown == "." else f"under {shown}/"
            asked = "/".join(prefix) + "/" if prefix else ""
            self.repair(
                f"the URDF asks for package://{asked}... and the upload has those files "
                f"{where}: read from there (fixed automatically)"
            )
        try:
            model = RobotModel(
                name=name,
                links=tuple(links),
                joints=tuple(joints),
                materials=dict(self.materials),
                sensors=ext["sensors"],
                spheres=ext["spheres"],
                tcp=ext["tcp"],
                metadata=ext["metadata"],
                source=self.source,
                repairs=tuple(self.repairs),
            )
        except ModelError as exc:
            raise ModelError(f"{self.source}: {exc}") from exc
        return model if _children(root, "robotrial") else completed(model)

    def check_tree(
        self,
        root: etree._Element,
        links: Mapping[str, etree._Element],
        joints: Sequence[Joint],
        joint_els: Mapping[str, etree._Element],
    ) -> None:
        joint_list = _children(root, "joint")
        first_line: dict[str, int] = {}
        for el in joint_list:
            n = el.get("name")
            if n in first_line:
                raise self.error(
                    el, f"joint {n!r} is defined twice (first at line {first_line[n]})"
                )
            first_line[n] = el.sourceline
        parent_of: dict[str, Joint] = {}
        for j in joints:
            el = joint_els[j.name]
            for role, ln in (("parent", j.parent), ("child", j.child)):
                if ln not in links:
                    raise self.error(el, f"{role} link {ln!r} does not exist")
            if j.parent == j.child:
                raise self.error(el, f"joint connects link {j.child!r} to itself")
            if j.child in parent_of:
                other = parent_of[j.child]
                raise self.error(
                    el,
                    f"link {j.child!r} already has parent joint {other.name!r} "
                    f"(line {joint_els[other.name].sourceline}); a URDF is a tree",
                )
            parent_of[j.child] = j
        roots = [n for n in links if n not in parent_of]
        if not roots:
            raise self.error(root, "the joints form a cycle: every link has a parent")
        if len(roots) > 1:
            raise self.error(
                root,
                f"the links form {len(roots)} separate trees with roots {roots}; "
                "a URDF has exactly one root link (connect them with joints)",
            )
        # every link must be reachable from the root, otherwise a cycle hides below it
        reachable = {roots[0]}
        children: dict[str, list[str]] = {}
        for j in joints:
            children.setdefault(j.parent, []).append(j.child)
        stack = [roots[0]]
        while stack:
            for c in children.get(stack.pop(), []):
                if c not in reachable:
                    reachable.add(c)
                    stack.append(c)
        cyc = [n for n in links if n not in reachable]
        if cyc:
            raise self.error(
                joint_els[parent_of[cyc[0]].name],
                f"links {cyc} form a cycle not connected to the root {roots[0]!r}",
            )

    def add_missing_masses(self, links: Sequence[Link], joints: Sequence[Joint]) -> list[Link]:
        """Give a small mass to each moving link that carries no mass, nor does anything
        below it (a physics engine cannot accelerate a massless body; MuJoCo refuses it)."""
        children: dict[str, list[str]] = {}
        for j in joints:
            children.setdefault(j.parent, []).append(j.child)
        own = {lk.name: (lk.inertial.mass if lk.inertial else 0.0) for lk in links}
        subtree: dict[str, float] = {}

        def mass_below(name: str) -> float:
            if name not in subtree:
                stack, total, seen = [name], 0.0, set()
                while stack:
                    n = stack.pop()
                    if n in seen:
                        continue
                    seen.add(n)
                    total += own[n]
                    stack.extend(children.get(n, []))
                subtree[name] = total
            return subtree[name]

        moving = {j.child for j in joints if j.type != "fixed"}
        out = []
        for lk in links:
            if lk.name in moving and mass_below(lk.name) <= 0:
                guess = self.guess_inertial(lk.visuals, lk.collisions)
                said = "has zero mass" if lk.name in self.zero_mass else "has no <inertial>"
                self.repair(
                    f"link {lk.name!r} moves but {said} (nor does anything attached below it); "
                    f"gave it {guess.mass:.4g} kg with the inertia of its bounding box"
                )
                lk = Link(lk.name, guess, lk.visuals, lk.collisions)
            out.append(lk)
        return out

    # --- materials --------------------------------------------------------------------

    def material(self, el: etree._Element, owner: str) -> Material:
        name = (el.get("name") or "").strip()
        color = _child(el, "color")
        texture = _child(el, "texture")
        rgba = DEFAULT_RGBA
        if color is not None:
            rgba = self.floats(color, "rgba", 4)
            if not all(0.0 <= c <= 1.0 for c in rgba):
                clipped = tuple(float(np.clip(c, 0.0, 1.0)) for c in rgba)
                self.repair(
                    f"material {name!r} of {owner}: color {rgba} outside [0, 1], "
                    f"clipped to {clipped}"
                )
                rgba = clipped
        tex = ""
        if texture is not None:
            fn = texture.get("filename")
            if fn:
                try:
                    tex = str(self.resolver.resolve(fn))
                except ResourceRefused as exc:
                    raise self.error(texture, f"texture of material {name!r}: {exc}") from None
                except ResourceNotFound as exc:
                    self.repair(
                        f"material {name!r} of {owner}: texture {fn!r} not found, dropped ({exc})"
                    )
        return Material(name, tuple(rgba), tex)  # type: ignore[arg-type]

    def visual_material(self, el: etree._Element, link: str, index: int) -> str:
        m = _child(el, "material")
        if m is None:
            return ""
        name = (m.get("name") or "").strip()
        inline = _child(m, "color") is not None or _child(m, "texture") is not None
        if inline:
            mat = self.material(m, owner=f"link {link!r}")
            if not name:
                name = f"{link}/visual/{index}"
                mat = Material(name, mat.rgba, mat.texture)
            known = self.materials.get(name)
            if known is None:
                self.materials[name] = mat
                self.material_lines[name] = m.sourceline or 0
            elif known != mat:
                # the same name with other colors: keep both, the later one renamed
                name = f"{name}@{link}/visual/{index}"
                self.materials[name] = Material(name, mat.rgba, mat.texture)
            return name
        if not name:
            return ""
        if name not in self.materials:
            self.repair(
                f"link {link!r} visual {index}: material {name!r} is not defined; "
                f"using grey {DEFAULT_RGBA}"
            )
            self.materials[name] = Material(name, DEFAULT_RGBA)
        return name

    # --- links ------------------------------------------------------------------------

    def link(self, el: etree._Element) -> Link:
        name = self.name(el, "<link>")
        visuals: list[Visual] = []
        for i, v in enumerate(_children(el, "visual")):
            geom = self.geometry(v, name, "visual", i)
            if geom is None:
                continue
            visuals.append(
                Visual(
                    geometry=geom,
                    origin=self.origin(v),
                    material=self.visual_material(v, name, i),
                    name=(v.get("name") or "").strip(),
                )
            )
        collisions: list[Collision] = []
        for i, c in enumerate(_children(el, "collision")):
            geom = self.geometry(c, name, "collision", i)
            if geom is None:
                continue
            collisions.append(
                Collision(geometry=geom, origin=self.origin(c), name=(c.get("name") or "").strip())
            )
        inertial = self.inertial(el, name, visuals, collisions)
        return Link(name, inertial, tuple(visuals), tuple(collisions))

    def geometry(self, el: etree._Element, link: str, kind: str, index: int) -> Shape | None:
        g = _child(el, "geometry")
        if g is None:
            raise self.error(el, f"{kind} {index} of link {link!r} has no <geometry>")
        shapes = [c for c in g if _tag(c)]
        if not shapes:
            raise self.error(g, f"{kind} {index} of link {link!r}: <geometry> holds no shape")
        s = shapes[0]
        if len(shapes) > 1:
            self.repair(
                f"{kind} {index} of link {link!r} (line {g.sourceline}): <geometry> holds "
                f"{[_tag(c) for c in shapes]}; the first, <{_tag(s)}>, is used (as ROS does)"
            )
        t = _tag(s)
        what = f"link {link!r} {kind} {index}"
        if t == "box":
            size = self.floats(s, "size", 3)
            return Box(self.positive(s, what, "size", size))
        if t == "cylinder":
            r = self.positive(s, what, "radius", (self.number(s, "radius"),))[0]
            ln = self.positive(s, what, "length", (self.number(s, "length"),))[0]
            return Cylinder(r, ln)
        if t == "sphere":
            return Sphere(self.positive(s, what, "radius", (self.number(s, "radius"),))[0])
        if t == "mesh":
            return self.mesh(s, link, kind, index)
        if t == "capsule":
            raise self.error(s, f"{what}: <capsule> is not part of URDF; use a cylinder")
        raise self.error(s, f"{what}: unknown shape <{t}> (box, cylinder, sphere or mesh)")

    def positive(
        self, el: etree._Element, what: str, attr: str, vals: Sequence[float]
    ) -> tuple[float, ...]:
        if any(v < 0 for v in vals):
            raise self.error(el, f"{what}: {attr} {tuple(vals)} is negative")
        if any(v == 0 for v in vals):
            fixed = tuple(v if v > 0 else SHAPE_MIN for v in vals)
            self.repair(f"{what}: {_tag(el)} {attr} {tuple(vals)} has a zero, set to {fixed}")
            return fixed
        return tuple(vals)

    def mesh(self, el: etree._Element, link: str, kind: str, index: int) -> Mesh | None:
        fn = (el.get("filename") or "").strip()
        what = f"link {link!r} {kind} {index}"
        if not fn:
            raise self.error(el, f"{what}: <mesh> has no filename")
        raw_scale = el.get("scale")
        scale: tuple[float, ...] = (1.0, 1.0, 1.0)
        if raw_scale is not None:
            parts = [p for p in _NUM_SPLIT.split(raw_scale.strip()) if p]
            scale = (
                self.floats(el, "scale", 1) * 3 if len(parts) == 1 else self.floats(el, "scale", 3)
            )
            if any(v == 0 for v in scale):
                raise self.error(el, f"{what}: mesh scale {scale} has a zero")
        problem = ""
        confined = self.resolver.confined is not None
        try:
            path = self.resolver.resolve(fn)
            if not mesh_format_supported(path):
                problem = (
                    f"format {path.suffix!r} cannot be read (file {self.resolver.shown(path)})"
                )
        except ResourceRefused as exc:
            raise self.error(el, f"{what}: mesh {exc}") from None
        except ResourceNotFound as exc:
            problem = "; ".join(exc.searched) if confined else str(exc)
        if problem:
            if kind == "visual":
                self.repair(f"{what}: mesh {fn!r} dropped: {problem}")
                return None
            hint = (
                "Put the package's folder with its meshes in the zip and upload it again"
                if confined
                else "Pass the folder that holds the package with --package-path "
                "(or set ROS_PACKAGE_PATH)"
            )
            raise self.error(el, f"{what}: collision mesh {fn!r}: {problem}. {hint}")
        return Mesh(str(path), scale)  # type: ignore[arg-type]

    # --- inertial ---------------------------------------------------------------------

    def inertial(
        self,
        el: etree._Element,
        link: str,
        visuals: Sequence[Visual],
        collisions: Sequence[Collision],
    ) -> Inertial | None:
        """The link's <inertial>; None for none or zero mass (a massless frame)."""
        ie = _child(el, "inertial")
        if ie is None:
            return None
        origin = self.origin(ie)
        m = _child(ie, "mass")
        mass = self.number(m, "value") if m is not None else 0.0
        ine = _child(ie, "inertia")
        keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        vals = {k: self.number(ine, k, 0.0) if ine is not None else 0.0 for k in keys}
        if mass == 0:
            self.zero_mass.add(link)
            return None
        if mass < 0:
            guess = self.guess_inertial(visuals, collisions)
            self.repair(
                f"link {link!r} (line {m.sourceline}): negative mass {mass:g} kg; set to "
                f"{guess.mass:.4g} kg with the inertia of its bounding box"
            )
            return guess
        inertial = Inertial(mass, origin, **vals)
        return self.valid_inertia(inertial, link, (ine if ine is not None else ie).sourceline)

    def valid_inertia(self, inertial: Inertial, link: str, line: int | None) -> Inertial:
        """The inertial with its tensor fixed if it is not positive definite or breaks the
        triangle inequality of principal moments (which MuJoCo rejects)."""
        tensor = inertial.tensor()
        fixed = nearest_valid_inertia(tensor, inertial.mass)
        if fixed is None:
            return inertial
        before = np.linalg.eigvalsh((tensor + tensor.T) / 2)
        after = np.linalg.eigvalsh(fixed)
        why = (
            "is not positive definite"
            if before[0] <= 0
            else "breaks the triangle inequality (a moment exceeds the sum of the others)"
        )
        self.repair(
            f"link {link!r} (line {line}): inertia with principal moments {_fmt(before)} "
            f"{why}; set to the nearest valid one, principal moments {_fmt(after)} "
            "about the same axes"
        )
        return Inertial(
            inertial.mass,
            inertial.origin,
            ixx=float(fixed[0, 0]),
            ixy=float(fixed[0, 1]),
            ixz=float(fixed[0, 2]),
            iyy=float(fixed[1, 1]),
            iyz=float(fixed[1, 2]),
            izz=float(fixed[2, 2]),
        )

    def guess_inertial(
        self, visuals: Sequence[Visual], collisions: Sequence[Collision]
    ) -> Inertial:
        """A small mass and the inertia of a solid box filling the geometry's bounds."""
        parts = collisions if collisions else visuals
        lows, highs = [], []
        for part in parts:
            try:
                lo, hi = shape_bounds(part.geometry)
            except ModelError:
                continue
            corners = np.array(
                [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
            )
            pts = transform_points(part.origin.matrix(), corners)
            lows.append(pts.min(axis=0))
            highs.append(pts.max(axis=0))
        if lows:
            lo, hi = np.min(lows, axis=0), np.max(highs, axis=0)
        else:
            lo, hi = np.zeros(3), np.zeros(3)
        size = np.maximum(hi - lo, REPAIR_MIN_EXTENT)
        mass = float(np.clip(REPAIR_DENSITY * np.prod(size), REPAIR_MASS_MIN, REPAIR_MASS_MAX))
        ixx, iyy, izz = box_inertia(mass, size)
        return Inertial(mass, Pose(tuple((lo + hi) / 2)), ixx=ixx, iyy=iyy, izz=izz)

    # --- joints -----------------------------------------------------------------------

    def joint(self, el: etree._Element, links: Mapping[str, etree._Element]) -> Joint:
        name = self.name(el, "<joint>")
        jtype = (el.get("type") or "").strip()
        if jtype not in JOINT_TYPES:
            raise self.error(el, f"unknown joint type {jtype!r} (one of {', '.join(JOINT_TYPES)})")
        ends = {}
        for role in ("parent", "child"):
            e = _child(el, role)
            if e is None or not (e.get("link") or "").strip():
                raise self.error(el, f"has no <{role} link=...>")
            ends[role] = e.get("link").strip()
        axis = (1.0, 0.0, 0.0)
        ae = _child(el, "axis")
        if ae is not None:
            axis = self.floats(ae, "xyz", 3, (1.0, 0.0, 0.0))
        if jtype in ("revolute", "continuous", "prismatic", "planar"):
            n = float(np.linalg.norm(axis))
            if n < 1e-9:
                self.repair(f"joint {name!r}: axis {axis} has zero length; set to (1, 0, 0)")
                axis = (1.0, 0.0, 0.0)
            elif abs(n - 1.0) > 1e-6:
                unit = tuple(float(a / n) for a in axis)
                self.repair(f"joint {name!r}: axis {axis} normalised to unit length")
                axis = unit
        limit = self.limit(el, name, jtype)
        dynamics = None
        de = _child(el, "dynamics")
        if de is not None:
            dynamics = JointDynamics(
                damping=self.number(de, "damping", 0.0), friction=self.number(de, "friction", 0.0)
            )
            if dynamics.damping < 0 or dynamics.friction < 0:
                raise self.error(de, "damping and friction must not be negative")
        mimic = None
        me = _child(el, "mimic")
        if me is not None:
            target = (me.get("joint") or "").strip()
            if not target:
                raise self.error(me, f"joint {name!r}: <mimic> has no joint attribute")
            mimic = Mimic(
                target, self.number(me, "multiplier", 1.0), self.number(me, "offset", 0.0)
            )
        return Joint(
            name=name,
            type=jtype,  # type: ignore[arg-type]
            parent=ends["parent"],
            child=ends["child"],
            origin=self.origin(el),
            axis=axis,  # type: ignore[arg-type]
            limit=limit,
            dynamics=dynamics,
            mimic=mimic,
        )

    def limit(self, el: etree._Element, name: str, jtype: str) -> JointLimit | None:
        le = _child(el, "limit")
        if le is None:
            if jtype == "revolute":
                self.repair(
                    f"joint {name!r} (line {el.sourceline}): revolute joint has no <limit>; "
                    "limited to [-pi, pi]"
                )
                return JointLimit(-math.pi, math.pi, 0.0, 0.0)
            if jtype == "prismatic":
                raise self.error(
                    el, "prismatic joint has no <limit> (URDF requires lower and upper)"
                )
            return None
        lower = self.number(le, "lower", 0.0)
        upper = self.number(le, "upper", 0.0)
        effort = self.number(le, "effort", 0.0)
        velocity = self.number(le, "velocity", 0.0)
        if effort < 0 or velocity < 0:
            fixed = (abs(effort), abs(velocity))
            self.repair(
                f"joint {name!r}: negative effort/velocity limit ({effort}, {velocity}); "
                f"using {fixed}"
            )
            effort, velocity = fixed
        if jtype == "revolute" and lower == upper == 0:
            self.repair(
                f"joint {name!r} (line {le.sourceline}): revolute joint with range [0, 0] "
                "(what exporters write for 'no limit'); limited to [-pi, pi]"
            )
            lower, upper = -math.pi, math.pi
        if jtype in ("revolute", "prismatic") and lower > upper:
            self.repair(
                f"joint {name!r} (line {le.sourceline}): lower limit {lower} > upper {upper}; "
                "swapped"
            )
            lower, upper = upper, lower
        return JointLimit(lower, upper, effort, velocity)

    def check_mimics(
        self, joints: Sequence[Joint], joint_els: Mapping[str, etree._Element]
    ) -> list[Joint]:
        """Joints with each <mimic> checked; a mimic of a missing joint is dropped."""
        by_name = {j.name: j for j in joints}
        out = []
        for j in joints:
            if j.mimic is not None:
                el = _child(joint_els[j.name], "mimic")
                if j.mimic.joint == j.name:
                    raise self.error(el, f"joint {j.name!r} mimics itself")
                target = by_name.get(j.mimic.joint)
                if target is None:
                    self.repair(
                        f"joint {j.name!r} (line {el.sourceline}) mimics joint "
                        f"{j.mimic.joint!r}, which does not exist; the mimic was dropped "
                        "and the joint is driven on its own"
                    )
                    j = replace(j, mimic=None)
                elif target.type not in ("revolute", "continuous", "prismatic"):
                    raise self.error(
                        el, f"joint {j.name!r} mimics {target.type} joint {target.name!r}"
                    )
            out.append(j)
        return out

    # --- the <robotrial> element --------------------------------------------------------

    def robotrial(self, root: etree._Element, links: set[str], joints: set[str]) -> dict[str, Any]:
        out: dict[str, Any] = {"sensors": (), "spheres": (), "tcp": "", "metadata": {}}
        found = _children(root, "robotrial")
        if not found:
            return out
        if len(found) > 1:
            raise self.error(
                found[1],
                f"a robot has at most one <robotrial> (first at line {found[0].sourceline})",
            )
        ext = found[0]
        metadata: dict[str, Any] = {}
        sensors: list[Sensor] = []
        spheres: list[CollisionSphere] = []
        groups: dict[str, list[str]] = {}
        poses: dict[str, dict[str, float]] = {}
        tcp = ""
        for el in ext:
            t = _tag(el)
            if not t:
                continue
            if t == "tcp":
                if tcp:
                    raise self.error(el, "more than one <tcp>")
                tcp = self.link_ref(el, "link", links)
            elif t == "group":
                gname = self.name(el, "<group>")
                if gname in groups:
                    raise self.error(el, f"group {gname!r} defined twice")
                groups[gname] = self.joint_refs(el, joints)
            elif t == "gripper":
                if "gripper" in metadata:
                    raise self.error(el, "more than one <gripper>")
                g: dict[str, Any] = {"joints": self.joint_refs(el, joints)}
                g["open"] = self.number(el, "open")
                g["closed"] = self.number(el, "closed")
                g["link"] = self.link_ref(el, "link", links) if el.get("link") else ""
                metadata["gripper"] = g
            elif t == "drive":
                if "drive" in metadata:
                    raise self.error(el, "more than one <drive>")
                d: dict[str, Any] = {"type": (el.get("type") or "").strip()}
                if not d["type"]:
                    raise self.error(el, "<drive> has no type (e.g. skid_steer, diff_drive)")
                for k in el.keys():
                    if k != "type":
                        d[k] = self.number(el, k)
                metadata["drive"] = d
            elif t == "pose":
                pname = self.name(el, "<pose>")
                if pname in poses:
                    raise self.error(el, f"pose {pname!r} defined twice")
                names = self.joint_refs(el, joints)
                values = self.floats(el, "values", len(names))
                poses[pname] = dict(zip(names, values, strict=True))
            elif t == "sensor":
                sensors.append(self.sensor(el, links))
            elif t == "sphere":
                center = self.floats(el, "center", 3)
                radius = self.number(el, "radius")
                if radius <= 0:
                    raise self.error(el, f"sphere radius {radius} must be positive")
                spheres.append(CollisionSphere(self.link_ref(el, "link", links), center, radius))
            else:
                raise self.error(
                    el,
                    f"unknown element <{t}> in <robotrial> "
                    "(tcp, group, pose, gripper, drive, sensor, sphere)",
                )
        names = [s.name for s in sensors]
        for s in sensors:
            if names.count(s.name) > 1:
                raise self.error(ext, f"sensor {s.name!r} is defined twice")
        if groups:
            metadata["groups"] = groups
        if poses:
            metadata["poses"] = poses
        out.update(sensors=tuple(sensors), spheres=tuple(spheres), tcp=tcp, metadata=metadata)
        return out

    def link_ref(self, el: etree._Element, attr: str, links: set[str]) -> str:
        ln = (el.get(attr) or "").strip()
        if not ln:
            raise self.error(el, f"missing attribute {attr!r}")
        if ln not in links:
            raise self.error(el, f"link {ln!r} does not exist")
        return ln

    def joint_refs(self, el: etree._Element, joints: set[str]) -> list[str]:
        raw = el.get("joints")
        if raw is None:
            raise self.error(el, "missing attribute 'joints'")
        names = [n for n in _NUM_SPLIT.split(raw.strip()) if n]
        if not names:
            raise self.error(el, "'joints' is empty")
        missing = [n for n in names if n not in joints]
        if missing:
            raise self.error(el, f"joints {missing} do not exist")
        return names

    def sensor(self, el: etree._Element, links: set[str]) -> Sensor:
        name = self.name(el, "<sensor>")
        stype = (el.get("type") or "").strip()
        if stype not in SENSOR_TYPES:
            raise self.error(
                el, f"unknown sensor type {stype!r} (one of {', '.join(SENSOR_TYPES)})"
            )
        rate = self.number(el, "rate", 10.0)
        if rate <= 0:
            raise self.error(el, f"rate {rate} Hz must be positive")
        params: dict[str, Any] = {}
        for p in _children(el, "param"):
            pname = self.name(p, "<param>")
            if p.get("value") is None:
                raise self.error(p, "missing attribute 'value'")
            params[pname] = _param_value(p.get("value"))
        return Sensor(
            name=name,
            type=stype,  # type: ignore[arg-type]
            link=self.link_ref(el, "link", links),
            origin=self.origin(el),
            rate_hz=rate,
            params=params,
        )


# --- shape and inertia helpers -------------------------------------------------------------


def _param_value(raw: str) -> int | float | str:
    """A sensor parameter: int if it reads as one, else float, else the text."""
    s = raw.strip()
    try:
        return int(s)
    except ValueError:
        pass
    try:
        return float(s)
    except ValueError:
        return s


def shape_bounds(shape: Shape) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounds of a shape in its own frame (meshes are read to find them)."""
    if isinstance(shape, Box):
        h = np.asarray(shape.size) / 2
        return -h, h
    if isinstance(shape, Cylinder):
        h = np.array([shape.radius, shape.radius, shape.length / 2])
        return -h, h
    if isinstance(shape, Sphere):
        h = np.full(3, shape.radius)
        return -h, h
    return mesh_bounds(shape)


def box_inertia(mass: float, size: Sequence[float]) -> tuple[float, float, float]:
    """Principal moments (ixx, iyy, izz) of a solid box of full edge lengths `size`."""
    x, y, z = (float(s) for s in size)
    k = mass / 12.0
    return k * (y * y + z * z), k * (x * x + z * z), k * (x * x + y * y)


def nearest_valid_inertia(tensor: np.ndarray, mass: float = 0.0) -> np.ndarray | None:
    """None if `tensor` is a physical inertia; else the nearest one that is.

    Physical: symmetric positive definite (every principal moment above INERTIA_FLOOR
    and a billionth of the largest), and each principal moment at most the sum of the
    other two. The fix keeps the principal axes, raises moments to a floor (that of
    `mass` spread over a millimetre, at least the limits above) and, when the triangle
    inequality fails, moves the largest moment down and the two others up by the same
    amount until it holds.
    """
    t = np.asarray(tensor, dtype=float)
    t = (t + t.T) / 2
    w, v = np.linalg.eigh(t)
    scale = float(np.max(np.abs(w)))
    least = max(INERTIA_FLOOR, 1e-9 * scale)
    a, b, c = w  # ascending
    if a >= least and a + b >= c - 1e-9 * scale:
        return None
    m = np.maximum(w, max(least, mass * 1e-6))
    if m[0] + m[1] < m[2]:
        # a hair past equality, so rounding cannot break the inequality again
        d = (m[2] - m[0] - m[1]) / 3.0 + 1e-9 * m[2]
        m = np.array([m[0] + d, m[1] + d, m[2] - d])
    fixed = v @ np.diag(m) @ v.T
    return (fixed + fixed.T) / 2


def _fmt(values: Sequence[float]) -> str:
    return "(" + ", ".join(f"{float(x):.4g}" for x in values) + ")"


__all__ = [
    "URDFRepairWarning",
    "box_inertia",
    "expand_xacro",
    "load_urdf",
    "nearest_valid_inertia",
    "shape_bounds",
    "urdf_from_string",
]
