"""Which link pairs of a robot the planner checks against each other: its self-collision
matrix, found the way MoveIt's Setup Assistant finds it (layer 2).

A pair is left out of the checks, with its reason, when
- `rigid`: no planning joint moves one relative to the other;
- `adjacent`: one planning joint joins them (links without collision shapes in between
  are looked through, as the Setup Assistant does);
- `default`: their real collision shapes touch at the zero pose (joint values clipped to
  the limits): meshes that overlap where a joint joins them, not a collision;
- `always`: their spheres (the planner's own model) touch in at least ALWAYS of the
  sampled configurations: the model could never tell such a pair apart;
- `never`: their real shapes touch in none of the sampled configurations.

Of the pairs left in, those whose spheres touch where their real shapes do not in at
least CLOSE of the samples are *close* pairs (a forearm passing a wrist 1-2 cm away):
the coarse spheres would refuse a share of the free space there, so the checks ask the
links' fine covers where the coarse ones touch (`RobotSpheres`).

Samples are uniform in the planning joints' limits, the other joints held where the
kinematics holds them. The spheres are asked first (cheap, compiled); MuJoCo's exact
check (`collision/contacts.py`) decides `default` and `never`. The matrix is a part of
the robot's sphere model (`RobotSpheres`), which is kept on disk per robot and joint group.
"""

from __future__ import annotations

from collections.abc import Sequence

import numba as nb
import numpy as np

from robotrial.collision.contacts import link_contacts
from robotrial.kinematics.chain import Kinematics

ALWAYS = 0.95  # the share of samples in contact that makes a pair "always" touching
CLOSE = 0.002  # the share of samples the spheres misjudge that makes a pair "close"
SAMPLES = 3000  # configurations sampled per robot and joint group
CHUNK = 500  # configurations whose sphere positions are held in memory at once
REASONS = ("rigid", "adjacent", "default", "always", "never")


def rigid_groups(kin: Kinematics) -> np.ndarray:
    """Index of the rigid group of each link (kinematics order): the nearest ancestor
    (or itself) whose joint a planning variable drives; links no planning joint
    separates share one."""
    group = np.arange(len(kin.link_names))
    for k in range(1, len(kin.link_names)):
        if kin.src[k] < 0:
            group[k] = group[kin.parent[k]]
    return group


@nb.njit(cache=True)
def _pair_hits(
    world: np.ndarray,
    radii: np.ndarray,
    starts: np.ndarray,
    ends: np.ndarray,
    pairs: np.ndarray,
) -> np.ndarray:
    """(N, P) True where any sphere of body pairs[p, 0] overlaps one of pairs[p, 1] in
    configuration n; `world` (N, S, 3) holds every sphere's centre."""
    n, p = world.shape[0], pairs.shape[0]
    out = np.zeros((n, p), dtype=np.bool_)
    for c in range(n):
        for k in range(p):
            a, b = pairs[k, 0], pairs[k, 1]
            hit = False
            for i in range(starts[a], ends[a]):
                for j in range(starts[b], ends[b]):
                    dx = world[c, i, 0] - world[c, j, 0]
                    dy = world[c, i, 1] - world[c, j, 1]
                    dz = world[c, i, 2] - world[c, j, 2]
                    r = radii[i] + radii[j]
                    if dx * dx + dy * dy + dz * dz <= r * r:
                        hit = True
                        break
                if hit:
                    break
            out[c, k] = hit
    return out


def sphere_contacts(
    kin: Kinematics,
    links: Sequence[str],
    spheres: Sequence[tuple[np.ndarray, np.ndarray]],
    pairs: np.ndarray,
    qs: np.ndarray,
) -> np.ndarray:
    """(N, P) where in the configurations of `qs` each body pair (indices into `links`,
    whose spheres are (centres in the link's frame, radii)) touches."""
    starts = np.cumsum([0] + [len(r) for _, r in spheres])
    radii = np.concatenate([r for _, r in spheres])
    index = np.array(
        [kin.link_index[name] for name, (_, r) in zip(links, spheres, strict=True) for _ in r]
    )
    local = np.vstack([c for c, _ in spheres])
    out = np.zeros((len(qs), len(pairs)), dtype=bool)
    for first in range(0, len(qs), CHUNK):
        poses = kin.fk(qs[first : first + CHUNK])[:, index]
        world = np.einsum("nsij,sj->nsi", poses[:, :, :3, :3], local) + poses[:, :, :3, 3]
        out[first : first + CHUNK] = _pair_hits(world, radii, starts[:-1], starts[1:], pairs)
    return out


def _structural(kin: Kinematics, links: Sequence[str]) -> dict[tuple[int, int], str]:
    """Body pairs that the tree alone leaves out: rigid and adjacent ones."""
    group = rigid_groups(kin)
    with_shapes = {group[kin.link_index[name]] for name in links}

    def parent_group(g: int) -> int:
        """The rigid group above group `g`, looking through groups without shapes."""
        p = kin.parent[g]
        while p >= 0 and group[p] not in with_shapes:
            p = kin.parent[group[p]]
        return group[p] if p >= 0 else -1

    gl = [group[kin.link_index[name]] for name in links]
    out: dict[tuple[int, int], str] = {}
    for i in range(len(links)):
        for j in range(i + 1, len(links)):
            gi, gj = gl[i], gl[j]
            if gi == gj:
                out[(i, j)] = "rigid"
            elif parent_group(gj) == gi or parent_group(gi) == gj:
                out[(i, j)] = "adjacent"
    return out


def self_collision_pairs(
    kin: Kinematics,
    links: Sequence[str],
    spheres: Sequence[tuple[np.ndarray, np.ndarray]],
    samples: int = SAMPLES,
    seed: int = 0,
) -> tuple[dict[tuple[str, str], str], set[tuple[str, str]]]:
    """The pairs of bodies to leave out of self-collision checks, each with its reason,
    and the close pairs among the others (see the module doc). `links[i]` is the link
    of body i and `spheres[i]` its spheres (centres in the link's frame, radii); keys
    are (links[i], links[j]), i < j."""
    reasons = _structural(kin, links)
    n = len(links)
    open_pairs = np.array(
        [(i, j) for i in range(n) for j in range(i + 1, n) if (i, j) not in reasons],
        dtype=np.int64,
    ).reshape(-1, 2)
    zero = np.clip(np.zeros(kin.d), kin.lower, kin.upper)[None]
    qs = kin.random(np.random.default_rng(seed), max(int(samples), 1))
    touched = sphere_contacts(kin, links, spheres, open_pairs, qs)
    rows, excluded = link_contacts(kin, np.vstack([zero, qs]))
    at_zero = rows[0] | excluded
    real = set().union(*rows[1:])
    close = set()
    for p, (i, j) in enumerate(map(tuple, open_pairs)):
        names = (min(links[i], links[j]), max(links[i], links[j]))
        count = int(touched[:, p].sum())
        if names in at_zero:
            reasons[(i, j)] = "default"
        elif count >= ALWAYS * len(qs):
            reasons[(i, j)] = "always"
        elif count == 0 or names not in real:
            reasons[(i, j)] = "never"
        else:
            wrong = sum(names not in rows[1 + n] for n in np.flatnonzero(touched[:, p]))
            if wrong >= CLOSE * len(qs):
                close.add((links[i], links[j]))
    return {(links[i], links[j]): why for (i, j), why in reasons.items()}, close


__all__ = ["ALWAYS", "CLOSE", "REASONS", "SAMPLES", "rigid_groups", "self_collision_pairs"]
