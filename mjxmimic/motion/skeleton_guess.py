"""A skeleton mapping for the humanoid guessed from a BVH file's own joint names and rest pose,
for skeletons that no shipped mapping (skeletons/*.json) fits: Mixamo's, Daz's, a game rig's.

Names are split into words (`mixamorig:LeftUpLeg` -> left, up, leg; `lShldr` -> l, shldr;
`UpperArm_L` -> upper, arm, l), which give the side and the part. Each limb is found from its end
up: the foot (or ankle) closest to the root, then the nearest ancestors named like a knee and a
thigh (else the parents), and likewise hand, forearm, upper arm. The root is where the two legs
meet, the chest where the arms and the head meet. The axes come from the rest pose where it stands
(up from the hips to the head, left from the right hip to the left one), else from the motion.
"""

from __future__ import annotations

import re

import numpy as np

from mjxmimic.motion.bvh import Bvh
from mjxmimic.motion.bvh_import import Mapping, rest_stands

CHARACTER = "humanoid"
SIDES = {"left": "left", "l": "left", "right": "right", "r": "right"}
FOOT, KNEE, THIGH = {"foot", "ankle"}, {"knee", "shin", "calf", "leg", "lowleg", "lowerleg", "tibia"}, \
    {"upleg", "upperleg", "thigh", "hip", "femur"}
HAND, ELBOW, UPPER_ARM = {"hand", "wrist"}, {"forearm", "elbow", "lowerarm", "lowarm", "radius"}, \
    {"arm", "upperarm", "uparm", "shoulder", "shldr", "humerus"}
NOT_A_LIMB_END = {"toe", "toes", "finger", "fingers", "thumb", "index", "middle", "ring", "pinky", "end"}
MIN_AXIS_COSINE = 0.8  # how close to a coordinate axis a rest-pose direction must be


class NoGuess(Exception):
    """Why no mapping could be guessed (a short phrase)."""


def words(name: str) -> list[str]:
    """A joint name's words, lower case, namespace dropped: 'mixamorig:LeftUpLeg' -> left, up, leg."""
    name = name.rsplit(":", 1)[-1]
    return [w.lower() for w in re.findall(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+", name)]


def side(name: str) -> str | None:
    found = {SIDES[w] for w in words(name) if w in SIDES}
    return found.pop() if len(found) == 1 else None


def named(name: str, synonyms: set[str]) -> bool:
    """Whether some run of the name's words (side and digits left out) spells one of the synonyms."""
    parts = [w for w in words(name) if w not in SIDES and not w.isdigit()]
    runs = {"".join(parts[i:j]) for i in range(len(parts)) for j in range(i + 1, len(parts) + 1)}
    return bool(runs & synonyms)


def guess_mapping(bvh: Bvh) -> Mapping:
    depth = [0] * len(bvh.joints)
    for j, joint in enumerate(bvh.joints):
        depth[j] = depth[joint.parent] + 1 if joint.parent >= 0 else 0

    def ancestors(j: int) -> list[int]:
        out = []
        while bvh.joints[j].parent >= 0:
            j = bvh.joints[j].parent
            out.append(j)
        return out

    def limb_end(limb_side: str, synonyms: set[str], what: str) -> int:
        found = [j for j, joint in enumerate(bvh.joints) if side(joint.name) == limb_side
                 and named(joint.name, synonyms) and not set(words(joint.name)) & NOT_A_LIMB_END]
        if not found:
            raise NoGuess(f"no joint named like a {limb_side} {what}")
        return min(found, key=lambda j: depth[j])

    def up_from(j: int, synonyms: set[str], what: str) -> int:
        above = [a for a in ancestors(j) if bvh.joints[a].parent >= 0]  # a limb's joint is not the root
        if not above:
            raise NoGuess(f"no joint above {bvh.joints[j].name} for the {what}")
        return next((a for a in above if named(bvh.joints[a].name, synonyms)), above[0])

    bodies: dict[str, int] = {}
    for limb_side in ("right", "left"):
        foot = limb_end(limb_side, FOOT, "foot or ankle")
        knee = up_from(foot, KNEE, "knee")
        bodies |= {f"{limb_side}_ankle": foot, f"{limb_side}_knee": knee,
                   f"{limb_side}_hip": up_from(knee, THIGH, "thigh")}
        hand = limb_end(limb_side, HAND, "hand or wrist")
        elbow = up_from(hand, ELBOW, "elbow")
        bodies |= {f"{limb_side}_wrist": hand, f"{limb_side}_elbow": elbow,
                   f"{limb_side}_shoulder": up_from(elbow, UPPER_ARM, "upper arm")}
    heads = [j for j, joint in enumerate(bvh.joints) if side(joint.name) is None and named(joint.name, {"head"})]
    if not heads:
        raise NoGuess("no joint named like a head")
    bodies["neck"] = min(heads, key=lambda j: depth[j])  # the humanoid's head is its body 'neck'

    def meeting(*joints: int) -> int:
        chains = [[j, *ancestors(j)] for j in joints]
        return next(a for a in chains[0] if all(a in chain for chain in chains[1:]))

    bodies["root"] = meeting(bodies["left_hip"], bodies["right_hip"])
    bodies["chest"] = meeting(bodies["left_shoulder"], bodies["right_shoulder"], bodies["neck"])
    if bodies["chest"] == bodies["root"] or bodies["root"] not in ancestors(bodies["chest"]):
        raise NoGuess("its arms and head do not meet above its hips")
    if len(set(bodies.values())) < len(bodies):
        raise NoGuess("two body parts fell on one joint")
    up, forward = _axes(bvh, bodies)
    parts = ("hip", "knee", "ankle", "shoulder", "elbow", "wrist")
    order = ["root", "chest", "neck"] + [f"{s}_{part}" for part in parts for s in ("right", "left")]
    return Mapping(None, up, forward, {b: bvh.joints[bodies[b]].name for b in order},
                   ("right_hip", "right_knee", "right_ankle"), ("right_hip", "left_hip"))


def _axes(bvh: Bvh, bodies: dict[str, int]) -> tuple[np.ndarray, np.ndarray]:
    """The source's up axis and a facing: from the rest pose where it stands (the facing at rest
    sets how each bone turns), else from the motion (up from the hips to the head on average; the
    facing then only turns the whole clip)."""
    rest = bvh.rest_positions()
    legs = [(bodies[f"{s}_{a}"], bodies[f"{s}_{b}"]) for s in ("left", "right")
            for a, b in (("hip", "knee"), ("knee", "ankle"))]
    try:
        up = _snap(rest[bodies["neck"]] - rest[bodies["root"]], "")
        left = _snap(rest[bodies["left_hip"]] - rest[bodies["right_hip"]], "")
        if abs(float(up @ left)) == 0 and rest_stands(rest, up, down=legs, up=[]):
            return up, np.cross(left, up)
    except NoGuess:
        pass
    pos, _ = bvh.forward_kinematics()
    spine = pos[:, bodies["neck"]] - pos[:, bodies["root"]]
    why = "neither its rest pose nor its motion stands (head above the hips, feet below)"
    up = _snap(np.mean(spine / np.maximum(np.linalg.norm(spine, axis=1, keepdims=True), 1e-12), axis=0), why)
    if float(np.mean(pos[:, bodies["left_ankle"]] - pos[:, bodies["root"]], axis=0) @ up) >= 0:
        raise NoGuess(why)
    lateral = np.mean(pos[:, bodies["left_hip"]] - pos[:, bodies["right_hip"]], axis=0)
    lateral[np.argmax(np.abs(up))] = 0.0
    k = int(np.argmax(np.abs(lateral))) if np.any(lateral) else int(np.argmin(np.abs(up)))
    left = np.zeros(3)
    left[k] = 1.0 if lateral[k] >= 0 else -1.0
    return up, np.cross(left, up)


def _snap(v: np.ndarray, why: str) -> np.ndarray:
    norm = float(np.linalg.norm(v))
    k = int(np.argmax(np.abs(v)))
    if norm == 0 or abs(v[k]) < MIN_AXIS_COSINE * norm:
        raise NoGuess(why)
    out = np.zeros(3)
    out[k] = np.sign(v[k])
    return out
