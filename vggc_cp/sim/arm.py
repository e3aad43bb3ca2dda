"""The robot look's arm: a Franka Panda from ``pybullet_data``, posed without physics.

Its hand rests above the place it last acted on: the joints come from PyBullet's inverse
kinematics toward a target above that region (:meth:`vggc_cp.sim.render.Scene.arm_target`),
always started from :data:`ARM_REST`, so a pose depends on its target only; the hand points
down with its fingers along x, and holds what is held between its finger pads. The base
stands behind the table and slides along its back edge (a rail) only as far as a region out
of reach needs. The arm is drawn with its coarse collision meshes, coloured, and collides with
nothing. :class:`~vggc_cp.sim.render.Scene` owns the PyBullet connection and calls these.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

from vggc_cp.errors import VggcError

#: The arm's base: this far (m) behind the layout table's back edge, at x = 0 -- or, where a
#: region lies more than ``ARM_REACH_X`` to the side, moved along the back edge (on a rail)
#: just enough to reach it.
ARM_BACK = 0.22
ARM_REACH_X = 0.40
#: Free height (m) between the top of what stands on the region and the bottom of the held
#: object (or the fingertips, with an empty hand) when the hand rests above a region.
ARM_CLEARANCE = 0.04
#: Panda joints 1-7 before the inverse kinematics (also its null-space rest pose): elbow up,
#: hand down. Every rest starts from it, so a pose depends on its target only.
ARM_REST = (0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785)
_ARM_JOINTS = (0, 1, 2, 3, 4, 5, 6)
_ARM_FINGERS = (9, 10)
_ARM_GRASP_LINK = 11  # panda_grasptarget: between the finger pads
_ARM_LIMITS = ((-2.9, 2.9), (-1.8, 1.8), (-2.9, 2.9), (-3.0, -0.07), (-2.9, 2.9), (-0.08, 3.8),
               (-2.9, 2.9))
#: Largest finger opening (m, per finger).
_ARM_FINGER_OPEN = 0.04
ARM_RGBA = (0.92, 0.92, 0.90, 1.0)
ARM_DARK_RGBA = (0.25, 0.25, 0.27, 1.0)
_ARM_DARK_LINKS = (6,)  # the flange (link 7)


def load_arm(p, cid: int, model: str) -> int:
    """Load the arm ``model`` (a URDF under ``pybullet_data``) into connection ``cid`` with
    its coarse meshes (the collision meshes, about 3,500 triangles, drawn as its visual: the
    full visual meshes, about 100,000, make the tiny renderer several times slower),
    coloured, not colliding with anything; returns its body id."""
    from vggc_cp.sim.looks import ARM_MODEL

    if model != ARM_MODEL:
        raise ValueError(f"unknown arm {model!r} (known: {ARM_MODEL})")
    import pybullet_data

    root = Path(pybullet_data.getDataPath()) / Path(model).parent
    text = (Path(pybullet_data.getDataPath()) / model).read_text()
    text = text.replace("meshes/visual/", "meshes/collision/")
    text = text.replace("package://meshes/", f"{root / 'meshes'}/")
    with tempfile.TemporaryDirectory(prefix="vggc-arm-") as tmp:
        path = Path(tmp) / "arm.urdf"
        path.write_text(text)
        arm = p.loadURDF(str(path), [0.0, 0.0, 0.0], useFixedBase=True,
                         physicsClientId=cid)
    if arm < 0:
        raise VggcError(f"PyBullet could not load the arm model {model}")
    for link in range(-1, p.getNumJoints(arm, physicsClientId=cid)):
        rgba = ARM_DARK_RGBA if link in _ARM_DARK_LINKS else ARM_RGBA
        p.changeVisualShape(arm, link, rgbaColor=list(rgba), physicsClientId=cid)
        p.setCollisionFilterGroupMask(arm, link, 0, 0, physicsClientId=cid)
    return arm


def arm_base(x: float, back_edge: float) -> tuple[float, float, float]:
    """Where the base stands to reach ``x`` (m): :data:`ARM_BACK` behind the table's back
    edge ``back_edge`` (its y), at x = 0 unless ``x`` lies more than :data:`ARM_REACH_X`
    to the side.

    >>> arm_base(0.1, 0.2), arm_base(0.6, 0.2)[0]
    ((0.0, 0.42000000000000004, 0.0), 0.19999999999999996)
    """
    bx = min(max(0.0, x - ARM_REACH_X), x + ARM_REACH_X)
    return bx, back_edge + ARM_BACK, 0.0


def pose_arm(p, cid: int, arm: int, base: tuple[float, float, float],
             target: tuple[float, float, float] | None, held_half: float | None
             ) -> tuple[float, float, float] | None:
    """Stand the arm at ``base`` and rest its grasp point at ``target`` (inverse kinematics
    from :data:`ARM_REST`, hand pointing down, fingers along x; the rest pose itself when
    ``target`` is None), the fingers closed on an object of half width ``held_half`` (open
    when None). Returns where the grasp point is, for the held object; None with an empty
    hand."""
    p.resetBasePositionAndOrientation(arm, list(base),
                                      p.getQuaternionFromEuler([0.0, 0.0, -math.pi / 2]),
                                      physicsClientId=cid)
    for j, v in zip(_ARM_JOINTS, ARM_REST):
        p.resetJointState(arm, j, v, physicsClientId=cid)
    if target is not None:
        lo = [a for a, _ in _ARM_LIMITS] + [0.0, 0.0]
        hi = [b for _, b in _ARM_LIMITS] + [_ARM_FINGER_OPEN] * 2
        q = p.calculateInverseKinematics(
            arm, _ARM_GRASP_LINK, list(target),
            p.getQuaternionFromEuler([math.pi, 0.0, -math.pi / 2]),
            lowerLimits=lo, upperLimits=hi, jointRanges=[b - a for a, b in zip(lo, hi)],
            restPoses=list(ARM_REST) + [_ARM_FINGER_OPEN] * 2, maxNumIterations=200,
            residualThreshold=1e-5, physicsClientId=cid)
        for j, v in zip(_ARM_JOINTS, q):
            p.resetJointState(arm, j, v, physicsClientId=cid)
    opening = _ARM_FINGER_OPEN
    if held_half is not None:
        opening = min(_ARM_FINGER_OPEN, held_half + 0.002)
    for j in _ARM_FINGERS:
        p.resetJointState(arm, j, opening, physicsClientId=cid)
    if held_half is None:
        return None
    return grasp_point(p, cid, arm)


def grasp_point(p, cid: int, arm: int) -> tuple[float, float, float]:
    """Where the arm's grasp point (between its finger pads) is now (world, m)."""
    pos = p.getLinkState(arm, _ARM_GRASP_LINK, computeForwardKinematics=True,
                         physicsClientId=cid)[4]
    return tuple(float(v) for v in pos)
