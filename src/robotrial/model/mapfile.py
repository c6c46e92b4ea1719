"""Occupancy maps as ROS map_server files: an image (PGM) and its YAML (layer 1).

The YAML holds `image` (path relative to the YAML), `resolution` (m/pixel), `origin`
([x, y, yaw] of the lower-left pixel), `negate`, `occupied_thresh`, `free_thresh` and
`mode` (trinary, scale or raw). Writing follows map_saver: occupied 0 (black), free 254
(white), unknown 205 (grey), the image's top row is the map's highest y. Reading follows
map_server: a pixel's occupancy is p = (255 - value) / 255 (value / 255 with `negate`);
in trinary mode p > occupied_thresh is 100, p < free_thresh is 0, else unknown (-1).
Cells are int8 in ROS OccupancyGrid order: row 0 is the lowest y.

A map made here may say where it lies: `robotrial: {world: NAME, frame_in_world: [x, y,
yaw]}` (the map frame's pose in that world, known in simulation: the base's true pose
when mapping began). map_server and Nav2's map server ignore keys they do not know; the
navigation trial reads it to start the robot in the map's frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from robotrial.model.robot import ModelError

FREE, OCCUPIED, UNKNOWN = 254, 0, 205
BAND_ROWS = 512
MODES = ("trinary", "scale", "raw")


@dataclass(frozen=True)
class OccupancyMap:
    """Cells (rows = y from the origin up, cols = x; -1 unknown, 0 free .. 100 occupied),
    metres per cell and the origin pose (x, y, yaw) of cell (0, 0)'s lower-left corner;
    where known, the world it maps and the map frame's pose (x, y, yaw) in that world."""

    data: np.ndarray
    resolution: float
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    world: str | None = None
    frame_in_world: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.data.ndim != 2:
            raise ModelError(f"occupancy map: data must be 2-D, got shape {self.data.shape}")
        if not self.resolution > 0:
            raise ModelError(f"occupancy map: resolution must be > 0, got {self.resolution}")

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        return int(self.data.shape[0])


def _paths(path: str | Path) -> tuple[Path, Path]:
    """(pgm, yaml) for a stem, a .yaml or a .pgm path."""
    p = Path(path)
    if p.suffix.lower() in (".yaml", ".yml", ".pgm"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".pgm"), p.with_name(p.name + ".yaml")


def write_map(
    path: str | Path,
    grid: OccupancyMap,
    occupied_thresh: float = 0.65,
    free_thresh: float = 0.196,
) -> tuple[Path, Path]:
    """Write `path`.pgm and `path`.yaml (map_saver's format); returns both paths.
    Cells >= occupied_thresh * 100 are black, 0 <= cell <= free_thresh * 100 white, the
    rest (and -1) grey."""
    pgm, yml = _paths(path)
    pgm.parent.mkdir(parents=True, exist_ok=True)
    data = np.asarray(grid.data)
    h, w = data.shape
    with open(pgm, "wb") as f:
        f.write(f"P5\n# CREATOR: robotrial {grid.resolution:.3f} m/pix\n{w} {h}\n255\n".encode())
        # The image's top row is the map's highest y; written a band of rows at a time,
        # so a large map (a campus at 2.5 cm) needs no image-sized copies.
        for top in range(h, 0, -BAND_ROWS):
            d = data[max(0, top - BAND_ROWS) : top][::-1].astype(np.int16)
            img = np.full(d.shape, UNKNOWN, dtype=np.uint8)
            img[(d >= 0) & (d <= free_thresh * 100)] = FREE
            img[d >= occupied_thresh * 100] = OCCUPIED
            f.write(img.tobytes())
    meta = {
        "image": pgm.name,
        "mode": "trinary",
        "resolution": float(grid.resolution),
        "origin": [float(v) for v in grid.origin],
        "negate": 0,
        "occupied_thresh": float(occupied_thresh),
        "free_thresh": float(free_thresh),
    }
    if grid.frame_in_world is not None:
        meta["robotrial"] = {
            "world": grid.world,
            "frame_in_world": [round(float(v), 6) for v in grid.frame_in_world],
        }
    yml.write_text(yaml.safe_dump(meta, sort_keys=False))
    return pgm, yml


def read_map(path: str | Path) -> OccupancyMap:
    """Read a map_server YAML (or the stem of one) and its image."""
    from PIL import Image

    _, yml = _paths(path)
    if Path(path).suffix.lower() in (".yaml", ".yml"):
        yml = Path(path)
    if not yml.is_file():
        raise ModelError(f"{yml}: no such map YAML")
    try:
        meta = yaml.safe_load(yml.read_text())
    except yaml.YAMLError as exc:
        raise ModelError(f"{yml}: not valid YAML: {exc}") from exc
    if not isinstance(meta, dict):
        raise ModelError(f"{yml}: expected a mapping with image, resolution, origin")
    for key in ("image", "resolution", "origin"):
        if key not in meta:
            raise ModelError(f"{yml}: missing {key!r} (map_server needs image, resolution, origin)")
    mode = str(meta.get("mode", "trinary"))
    if mode not in MODES:
        raise ModelError(f"{yml}: mode {mode!r} is not one of {', '.join(MODES)}")
    origin = meta["origin"]
    if not isinstance(origin, list | tuple) or len(origin) != 3:
        raise ModelError(f"{yml}: origin must be [x, y, yaw], got {origin!r}")
    image = Path(str(meta["image"]))
    if not image.is_absolute():
        image = yml.parent / image
    if not image.is_file():
        raise ModelError(f"{yml}: image {image} not found")
    with Image.open(image) as im:
        pix = np.asarray(im.convert("L"), dtype=np.float64)
    occ_t = float(meta.get("occupied_thresh", 0.65))
    free_t = float(meta.get("free_thresh", 0.196))
    negate = bool(int(meta.get("negate", 0)))
    p = pix / 255.0 if negate else (255.0 - pix) / 255.0
    out = np.full(pix.shape, -1, dtype=np.int8)
    if mode == "raw":
        out = np.clip(pix, -1, 100).astype(np.int8)
    else:
        out[p > occ_t] = 100
        out[p < free_t] = 0
        if mode == "scale":
            mid = (p >= free_t) & (p <= occ_t)
            out[mid] = np.round(99 * (p[mid] - free_t) / (occ_t - free_t)).astype(np.int8)
    world, frame = _made_here(meta.get("robotrial"), yml)
    return OccupancyMap(
        out[::-1].copy(), float(meta["resolution"]), tuple(map(float, origin)), world, frame
    )


def _made_here(extra, yml: Path) -> tuple[str | None, tuple[float, float, float] | None]:
    """The `robotrial` section of a map YAML: (world, frame_in_world), or Nones."""
    if extra is None:
        return None, None
    frame = extra.get("frame_in_world") if isinstance(extra, dict) else None
    try:
        pose = tuple(float(v) for v in frame)
    except (TypeError, ValueError):
        pose = ()
    if len(pose) != 3 or not all(np.isfinite(pose)):
        raise ModelError(f"{yml}: robotrial.frame_in_world must be [x, y, yaw], got {frame!r}")
    world = extra.get("world")
    return (None if world is None else str(world)), pose  # type: ignore[return-value]
