"""PyBullet scenes: a table with marked regions, fruit or cubes, a gripper, one fixed camera.

A :class:`Scene` owns one PyBullet connection in DIRECT mode (no window) and renders with the
CPU tiny renderer, so it runs headless and gives the same pixels on every machine. Bodies are
built once and moved with ``resetBasePositionAndOrientation`` for every frame; cubes are
settled with a few physics steps so that stacks rest on each other.

Objects (primitive shapes, coloured): apple a red sphere with a stem, strawberry a red
cone-like mesh with a green cap, lemon a yellow ellipsoid, banana a yellow capsule; blocks
are blue cubes. The held object hangs between the two fingers of a gripper behind the table.
The ``randomized`` look (:mod:`vggc_cp.sim.looks`) adds tomato (red, flattened, green
calyx) and pear (yellow), and varies colours, sizes, camera, light and the table's texture.
The ``robot`` look replaces the fixed gripper by a Franka Panda arm (``pybullet_data``,
:mod:`vggc_cp.sim.arm`) whose hand rests above the region it last acted on (joints from
PyBullet's inverse kinematics, no physics), holding the held object, and adds a mug (the
distractor) that :meth:`Scene.move_distractor` puts on the table outside every region.
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.sim.arm import ARM_CLEARANCE, arm_base, grasp_point, load_arm, pose_arm
from vggc_cp.sim.arrange import Arrangement
from vggc_cp.sim.dynamics import Benchmark
from vggc_cp.sim.looks import CLASS_RGBA, Look, clean_look, png_bytes, texture_image
from vggc_cp.sim.meshes import ellipsoid, strawberry

#: Centre-to-centre distance of neighbouring regions (m).
PITCH = 0.16
#: Side of a region's square marker (m).
REGION_SIDE = 0.13
#: Cube side (m).
CUBE = 0.05
#: Stackable shapes of the task family besides the cube: cylinder (radius, half height),
#: brick (half extents); metres at scale 1.
SOLIDS = {"cube": (CUBE / 2,), "cylinder": (0.027, 0.024), "brick": (0.036, 0.021, 0.018)}
#: Physics steps (at 240 Hz) that settle the cubes of a frame.
SETTLE_STEPS = 24
#: Margin of the table around the regions (m).
MARGIN = 0.05
#: Height of the held object's centre above the table (m).
HELD_Z = 0.14
#: Distance of the gripper behind the table's back edge (m).
GRIPPER_BACK = -0.01

_MUG_INSIDE = (0.12, 0.1, 0.08, 1.0)

# Table, region and marker colours are the look's (vggc_cp.sim.looks).
GRIPPER_RGBA = (0.55, 0.57, 0.62, 1.0)
CUBE_RGBA = CLASS_RGBA["block"]

_RED = CLASS_RGBA["red"]
_YELLOW = CLASS_RGBA["yellow"]
_GREEN = (0.15, 0.6, 0.15, 1.0)
_BROWN = (0.4, 0.25, 0.1, 1.0)


def import_pybullet():
    """Import PyBullet without its build-time banner on stderr.

    Raises
    ------
    VggcError
        When PyBullet is not installed.
    """
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.close(devnull)
        import pybullet
    except ImportError as exc:
        raise VggcError(f"rendering needs PyBullet (pip install pybullet): {exc}") from None
    finally:
        os.dup2(saved, 2)
        os.close(saved)
    return pybullet


@dataclass(frozen=True)
class Camera:
    """The fixed camera of a benchmark (PyBullet conventions; metres and degrees)."""

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float]
    fov: float
    near: float
    far: float
    light_direction: tuple[float, float, float]

    def as_dict(self) -> dict:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}


@dataclass(frozen=True)
class Layout:
    """Geometry of a benchmark's scene.

    Attributes
    ----------
    centres : ndarray, float, shape (R, 2)
        Region centres (x to the right, y away from the camera), table top at z = 0.
    half_extent : tuple of float
        Half size of the table top (x, y).
    gripper : tuple of float
        Centre of the held object (x, y, z).
    camera : Camera
    """

    centres: np.ndarray
    half_extent: tuple[float, float]
    gripper: tuple[float, float, float]
    camera: Camera


def scene_layout(bench: Benchmark) -> Layout:
    """Region centres, table, gripper and camera of ``bench`` (row 0 is the back row; a
    scattered task's centres are its spec's)."""
    rows, cols = bench.spec.grid
    if bench.spec.centres is not None:
        centres = np.array(bench.spec.centres, dtype=np.float64)
        hx = float(np.abs(centres[:, 0]).max()) + PITCH / 2 + MARGIN
        hy = float(np.abs(centres[:, 1]).max()) + PITCH / 2 + MARGIN
    else:
        r = np.arange(bench.spec.R)
        cx = (r % cols - (cols - 1) / 2) * PITCH
        cy = ((rows - 1) / 2 - r // cols) * PITCH
        centres = np.stack([cx, cy], axis=1)
        hx = cols * PITCH / 2 + MARGIN
        hy = rows * PITCH / 2 + MARGIN
    gripper = (0.0, hy + GRIPPER_BACK, HELD_Z)
    # camera in front of and above the table, looking at its centre
    span = max(2 * hx, 2 * hy + 0.2)
    fov = 45.0
    dist = 0.5 * span / math.tan(math.radians(fov / 2)) + 0.04
    pitch = math.radians(58.0)
    target = (0.0, 0.03, 0.07)
    eye = (0.0, target[1] - dist * math.cos(pitch), target[2] + dist * math.sin(pitch))
    cam = Camera(tuple(round(v, 6) for v in eye), target, (0.0, 0.0, 1.0), fov, 0.05, 5.0,
                 (0.4, -0.6, 1.0))
    return Layout(centres, (hx, hy), gripper, cam)


def look_camera(cam: Camera, look: Look) -> Camera:
    """``cam`` moved and turned by ``look`` (``cam`` itself for the clean look): eye and
    target move together by ``look.camera_shift`` times the view's width at the target; the
    eye turns about the target by the yaw and pitch of ``look.camera_turn``, the up vector
    by its roll; the light direction is the look's."""
    if look.is_clean:
        return cam
    eye, target = np.array(cam.eye), np.array(cam.target)
    d = eye - target
    dist = float(np.linalg.norm(d))
    width = 2 * dist * math.tan(math.radians(cam.fov / 2))
    yaw, pitch, roll = (math.radians(v) for v in look.camera_turn)
    az = math.atan2(d[1], d[0]) + yaw
    el = math.asin(d[2] / dist) + pitch
    new_target = target + width * np.array(look.camera_shift)
    new_eye = new_target + dist * np.array([math.cos(el) * math.cos(az),
                                            math.cos(el) * math.sin(az), math.sin(el)])
    forward = (new_target - new_eye) / dist
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = math.cos(roll) * np.array([0.0, 0.0, 1.0]) + math.sin(roll) * right
    r6 = lambda v: tuple(round(float(x), 6) for x in v)  # noqa: E731
    return replace(cam, eye=r6(new_eye), target=r6(new_target), up=r6(up),
                   light_direction=r6(look.light_direction))


def image_shape(size) -> tuple[int, int]:
    """``(height, width)`` of an image size: one side (square) or ``(height, width)``."""
    if isinstance(size, (tuple, list)):
        h, w = size
        return int(h), int(w)
    return int(size), int(size)


class Scene:
    """One benchmark's PyBullet scene; renders :class:`Arrangement` values to RGB arrays.

    Parameters
    ----------
    bench : Benchmark
    size : int or (int, int)
        Image side in pixels (square images), or ``(height, width)``: a wider image sees
        more of the table's sides at the same vertical field of view.
    look : Look, optional
        Colours, texture, camera, light and object shapes (:mod:`vggc_cp.sim.looks`); the
        clean look when None. Per-frame effects are not applied here
        (:func:`vggc_cp.sim.looks.finish_frame`).

    Use as a context manager, or call :meth:`close`, to release the connection.

    Attributes
    ----------
    camera : Camera
        The camera actually used (the layout's, moved by the look).
    """

    def __init__(self, bench: Benchmark, size: int = 64, look: Look | None = None) -> None:
        p = import_pybullet()
        self._p = p
        self.bench = bench
        self.height, self.width = image_shape(size)
        self.size = self.height
        self.layout = scene_layout(bench)
        self.look = clean_look(bench) if look is None else look
        if len(self.look.objects) != bench.spec.m:
            raise ValueError(f"look has {len(self.look.objects)} objects, {bench.spec.name} "
                             f"{bench.spec.m}")
        self.camera = look_camera(self.layout.camera, self.look)
        self._cid = p.connect(p.DIRECT)
        try:
            self._build()
        except Exception:
            p.disconnect(self._cid)
            raise
        cam = self.camera
        self._view = p.computeViewMatrix(cam.eye, cam.target, cam.up)
        self._proj = p.computeProjectionMatrixFOV(cam.fov, self.width / self.height, cam.near,
                                                  cam.far)

    # --------------------------------------------------------------- building
    def _visual(self, shape, rgba, **kw) -> int:
        return self._p.createVisualShape(shape, rgbaColor=list(rgba), physicsClientId=self._cid,
                                         **kw)

    def _multibody(self, parts, mass: float = 0.0, collision: int = -1,
                   position=(0.0, 0.0, -10.0)) -> int:
        """A body from visual parts ``[(visual id, local position), ...]``; the first is the base."""
        p = self._p
        base, rest = parts[0], parts[1:]
        n = len(rest)
        return p.createMultiBody(
            baseMass=mass, baseCollisionShapeIndex=collision, baseVisualShapeIndex=base[0],
            basePosition=list(position),
            linkMasses=[0.0] * n, linkCollisionShapeIndices=[-1] * n,
            linkVisualShapeIndices=[v for v, _ in rest],
            linkPositions=[list(pos) for _, pos in rest],
            linkOrientations=[[0, 0, 0, 1]] * n, linkInertialFramePositions=[[0, 0, 0]] * n,
            linkInertialFrameOrientations=[[0, 0, 0, 1]] * n, linkParentIndices=[0] * n,
            linkJointTypes=[p.JOINT_FIXED] * n, linkJointAxis=[[0, 0, 1]] * n,
            physicsClientId=self._cid)

    def _fruit(self, kind: str, rgba=None, s: float = 1.0) -> tuple[int, float]:
        """A fruit body of ``kind`` in colour ``rgba`` (the class colour when None), every
        length times ``s``; returns the body and the rest height of its centre."""
        p = self._p
        if kind == "apple":
            r = 0.032 * s
            parts = [(self._visual(p.GEOM_SPHERE, rgba or _RED, radius=r), None),
                     (self._visual(p.GEOM_CYLINDER, _BROWN, radius=0.004 * s,
                                   length=0.018 * s), (0, 0, r + 0.006 * s)),
                     (self._visual(p.GEOM_BOX, _GREEN,
                                   halfExtents=[0.012 * s, 0.005 * s, 0.002 * s]),
                      (0.01 * s, 0, r + 0.008 * s))]
            return self._multibody(parts), r
        if kind == "strawberry":
            verts, idx = strawberry(0.034 * s, 0.012 * s, -0.036 * s)
            parts = [(self._visual(p.GEOM_MESH, rgba or _RED, vertices=verts, indices=idx),
                      None),
                     (self._visual(p.GEOM_CYLINDER, _GREEN, radius=0.011 * s,
                                   length=0.005 * s), (0, 0, 0.021 * s)),
                     (self._visual(p.GEOM_CYLINDER, _GREEN, radius=0.003 * s,
                                   length=0.012 * s), (0, 0, 0.028 * s))]
            return self._multibody(parts), 0.04 * s
        if kind == "tomato":
            a, c = 0.036 * s, 0.027 * s
            verts, idx = ellipsoid(a, a, c)
            sepal = self._visual(p.GEOM_BOX, _GREEN,
                                 halfExtents=[0.014 * s, 0.0035 * s, 0.0015 * s])
            parts = [(self._visual(p.GEOM_MESH, rgba or _RED, vertices=verts, indices=idx),
                      None),
                     (self._visual(p.GEOM_CYLINDER, _GREEN, radius=0.008 * s,
                                   length=0.004 * s), (0, 0, c)),
                     (sepal, (0, 0, c + 0.001 * s)),
                     (self._visual(p.GEOM_BOX, _GREEN,
                                   halfExtents=[0.0035 * s, 0.014 * s, 0.0015 * s]),
                      (0, 0, c + 0.001 * s)),
                     (self._visual(p.GEOM_CYLINDER, _GREEN, radius=0.0025 * s,
                                   length=0.01 * s), (0, 0, c + 0.006 * s))]
            return self._multibody(parts), c
        if kind == "lemon":
            verts, idx = ellipsoid(0.045 * s, 0.03 * s, 0.03 * s)
            parts = [(self._visual(p.GEOM_MESH, rgba or _YELLOW, vertices=verts, indices=idx),
                      None),
                     (self._visual(p.GEOM_SPHERE, (0.7, 0.75, 0.1, 1.0), radius=0.008 * s),
                      (0.043 * s, 0, 0))]
            return self._multibody(parts), 0.03 * s
        if kind == "banana":
            r, length = 0.017 * s, 0.075 * s
            lying = p.getQuaternionFromEuler([0, math.pi / 2, 0])
            parts = [(self._visual(p.GEOM_CAPSULE, rgba or _YELLOW, radius=r, length=length,
                                   visualFrameOrientation=lying), None),
                     (self._visual(p.GEOM_SPHERE, _BROWN, radius=0.007 * s),
                      (length / 2 + r - 0.003 * s, 0, 0.003 * s))]
            return self._multibody(parts), r
        if kind == "pear":
            r, top = 0.031 * s, 0.02 * s
            parts = [(self._visual(p.GEOM_SPHERE, rgba or _YELLOW, radius=r), None),
                     (self._visual(p.GEOM_SPHERE, rgba or _YELLOW, radius=top),
                      (0, 0, 0.03 * s)),
                     (self._visual(p.GEOM_CYLINDER, _BROWN, radius=0.003 * s,
                                   length=0.014 * s), (0, 0, 0.03 * s + top + 0.004 * s))]
            return self._multibody(parts), r
        raise ValueError(f"unknown fruit kind {kind!r}")

    def _solid(self, kind: str, rgba, s: float = 1.0) -> tuple[int, float]:
        """A stackable body of ``kind`` (:data:`SOLIDS`) without collision (posed exactly,
        stacks rest on each other by construction); returns the body and its half height."""
        p = self._p
        if kind == "cube":
            h = CUBE / 2 * s
            vis = self._visual(p.GEOM_BOX, rgba, halfExtents=[h, h, h])
        elif kind == "cylinder":
            h = SOLIDS["cylinder"][1] * s
            vis = self._visual(p.GEOM_CYLINDER, rgba, radius=SOLIDS["cylinder"][0] * s,
                               length=2 * h)
        elif kind == "brick":
            hx, hy, h = (v * s for v in SOLIDS["brick"])
            vis = self._visual(p.GEOM_BOX, rgba, halfExtents=[hx, hy, h])
        else:
            raise ValueError(f"unknown solid kind {kind!r}")
        return self._multibody([(vis, None)]), h

    def _build(self) -> None:
        p, cid, lay = self._p, self._cid, self.layout
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        hx, hy = (h + self.look.table_extra for h in lay.half_extent)
        thick = 0.02
        table_col = p.createCollisionShape(p.GEOM_BOX, halfExtents=[hx, hy, thick],
                                           physicsClientId=cid)
        look = self.look
        table_vis = self._visual(p.GEOM_BOX, look.table_rgba, halfExtents=[hx, hy, thick])
        table = p.createMultiBody(0, table_col, table_vis, [0, 0, -thick], physicsClientId=cid)
        if look.table_texture is not None:
            self._texture(table, texture_image(look.table_texture, look.texture_seed))
        half = REGION_SIDE / 2
        border = self._visual(p.GEOM_BOX, look.border_rgba, halfExtents=[half + 0.006,
                                                                        half + 0.006, 0.0005])
        inner = self._visual(p.GEOM_BOX, look.region_rgba, halfExtents=[half, half, 0.0005])
        for cx, cy in lay.centres:
            p.createMultiBody(0, -1, border, [cx, cy, 0.0003], physicsClientId=cid)
            p.createMultiBody(0, -1, inner, [cx, cy, 0.0008], physicsClientId=cid)
        # gripper: a wrist, a palm and two fingers around the held object's centre
        gx, gy, gz = lay.gripper
        wrist = self._visual(p.GEOM_CYLINDER, GRIPPER_RGBA, radius=0.012, length=0.12)
        palm = self._visual(p.GEOM_BOX, GRIPPER_RGBA, halfExtents=[0.066, 0.014, 0.01])
        finger = self._visual(p.GEOM_BOX, GRIPPER_RGBA, halfExtents=[0.006, 0.012, 0.04])
        self._gripper = self._multibody(
            [(palm, None), (wrist, (0, 0, 0.07)), (finger, (-0.06, 0, -0.035)),
             (finger, (0.06, 0, -0.035))], position=(gx, gy, gz + 0.06))
        self._bodies: list[int] = []
        self._rest: list[float] = []
        if self.bench.blocks:
            shapes: dict = {}
            for obj in look.objects:
                key = (obj.scale, obj.rgba)
                if key not in shapes:  # the clean look: one shape for all cubes
                    h = CUBE / 2 * obj.scale
                    shapes[key] = (p.createCollisionShape(p.GEOM_BOX, halfExtents=[h, h, h],
                                                          physicsClientId=cid),
                                   self._visual(p.GEOM_BOX, obj.rgba, halfExtents=[h, h, h]), h)
                col, vis, h = shapes[key]
                body = p.createMultiBody(0.1, col, vis, [0, 0, -10], physicsClientId=cid)
                p.changeDynamics(body, -1, lateralFriction=0.9, physicsClientId=cid)
                self._bodies.append(body)
                self._rest.append(h)
        else:
            for obj in look.objects:
                make = self._solid if obj.kind in SOLIDS else self._fruit
                body, rest = make(obj.kind, obj.rgba, obj.scale)
                self._bodies.append(body)
                self._rest.append(rest)
        self._arm = (-1 if look.arm is None or look.arm_hidden
                     else load_arm(self._p, self._cid, look.arm))
        self._mug = -1
        #: Where the distractor stands: ``(x, y, yaw)``, or None (no distractor, or not yet
        #: placed: it starts out of sight).
        self.distractor_spot: tuple[float, float, float] | None = None
        if look.distractor is not None:
            self._mug = self._build_mug()

    def _build_mug(self) -> int:
        """The distractor: a cylinder, a dark opening on top and a handle (out of sight
        until :meth:`move_distractor`)."""
        p = self._p
        d = self.look.distractor
        r, h = d.radius, d.height
        handle = (self._visual(p.GEOM_BOX, d.rgba, halfExtents=[0.004, 0.004, 0.3 * h]),
                  (r + 0.014, 0.0, 0.0))
        stub = self._visual(p.GEOM_BOX, d.rgba, halfExtents=[0.008, 0.004, 0.004])
        return self._multibody(
            [(self._visual(p.GEOM_CYLINDER, d.rgba, radius=r, length=h), None),
             (self._visual(p.GEOM_CYLINDER, _MUG_INSIDE, radius=0.82 * r, length=0.002),
              (0.0, 0.0, h / 2)),
             handle, (stub, (r + 0.007, 0.0, 0.28 * h)), (stub, (r + 0.007, 0.0, -0.28 * h))])

    def _texture(self, body: int, image: np.ndarray) -> None:
        """Give ``body`` the texture ``image`` (through a temporary PNG file)."""
        p = self._p
        with tempfile.TemporaryDirectory(prefix="vggc-texture-") as tmp:
            path = Path(tmp) / "texture.png"
            path.write_bytes(png_bytes(image))
            tex = p.loadTexture(str(path), physicsClientId=self._cid)
        if tex < 0:
            raise VggcError("PyBullet could not load the generated table texture")
        p.changeVisualShape(body, -1, textureUniqueId=tex, physicsClientId=self._cid)

    # -------------------------------------------------------------- rendering
    def _put(self, body: int, xyz, yaw: float) -> None:
        p = self._p
        q = p.getQuaternionFromEuler([0.0, 0.0, yaw])
        p.resetBasePositionAndOrientation(body, list(xyz), q, physicsClientId=self._cid)
        p.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=self._cid)

    def pose(self, arr: Arrangement) -> None:
        """Move the bodies to ``arr`` (and settle cubes)."""
        lay = self.layout
        gx, gy, gz = lay.gripper
        for r, stack in enumerate(arr.stacks):
            cx, cy = lay.centres[r]
            base = 0.0  # top of the cubes below (a look with cubes of several sizes)
            for level, b in enumerate(stack):
                dx, dy, yaw = arr.offsets[b]
                if not self.bench.blocks:  # fruit never stack; a task's solids may
                    z = base + self._rest[b] + (0.0005 * level if level else 0.0)
                    base += 2 * self._rest[b]
                elif self.look.is_clean:
                    z = self._rest[b] + (level * CUBE + 0.0005 * (level + 1))
                else:
                    z = base + self._rest[b] + 0.0005 * (level + 1)
                    base += 2 * self._rest[b]
                self._put(self._bodies[b], (cx + dx, cy + dy, z), yaw)
        if arr.held >= 0 and self.bench.blocks:
            self._put(self._bodies[arr.held], (10.0, 10.0, 1.0), 0.0)
        if self.bench.blocks:
            for _ in range(SETTLE_STEPS):
                self._p.stepSimulation(physicsClientId=self._cid)
        if self._arm >= 0:
            self._pose_arm(arr)
            return
        jx = jy = 0.0
        if arr.held >= 0:
            jx, jy, jyaw = arr.offsets[arr.held]
            self._put(self._bodies[arr.held], (gx + jx, gy + jy, gz), math.pi / 2 + jyaw)
        self._p.resetBasePositionAndOrientation(self._gripper, [gx + jx, gy + jy, gz + 0.06],
                                                [0, 0, 0, 1], physicsClientId=self._cid)

    def _stack_top(self, arr: Arrangement, region: int) -> float:
        """Height (m) of the top of what stands on ``region`` (0: nothing)."""
        if not arr.stacks[region]:
            return 0.0
        top = arr.stacks[region][-1]
        z = self._p.getBasePositionAndOrientation(self._bodies[top],
                                                  physicsClientId=self._cid)[0][2]
        return z + self._rest[top] + (0.0 if self.bench.blocks else 0.012)  # fruit stalks

    def arm_target(self, arr: Arrangement) -> tuple[float, float, float] | None:
        """Where the arm's grasp point rests for ``arr`` (after :meth:`pose` of it): above
        ``arr.last_region`` -- plus the held object's offset -- high enough to clear what
        stands there; None when ``last_region`` is -1 (the arm's rest pose)."""
        r = arr.last_region
        if r < 0:
            return None
        cx, cy = self.layout.centres[r]
        lift = ARM_CLEARANCE + 0.02
        if arr.held >= 0:
            dx, dy, _ = arr.offsets[arr.held]
            cx, cy = cx + dx, cy + dy
            lift = ARM_CLEARANCE + self._rest[arr.held]
        return float(cx), float(cy), self._stack_top(arr, r) + lift

    def _pose_arm(self, arr: Arrangement) -> None:
        """Hide the fixed gripper; pose the arm above ``arr.last_region``
        (:func:`vggc_cp.sim.arm.pose_arm`) and put the held object between its fingers."""
        p, cid = self._p, self._cid
        p.resetBasePositionAndOrientation(self._gripper, [0.0, 0.0, -10.0], [0, 0, 0, 1],
                                          physicsClientId=cid)
        target = self.arm_target(arr)
        base = arm_base(0.0 if target is None else target[0], self.layout.half_extent[1])
        grasp = pose_arm(p, cid, self._arm, base, target,
                         self._rest[arr.held] if arr.held >= 0 else None)
        if arr.held >= 0:
            _, _, jyaw = arr.offsets[arr.held]
            self._put(self._bodies[arr.held], grasp, math.pi / 2 + jyaw)

    def grasp_point(self) -> tuple[float, float, float]:
        """Where the arm's grasp point is now (world, m); the robot look only."""
        if self._arm < 0:
            raise ValueError("this scene has no arm")
        return grasp_point(self._p, self._cid, self._arm)

    def project(self, xyz) -> tuple[float, float]:
        """Pixel ``(column, row)`` of the world point ``xyz`` in this scene's camera."""
        view = np.array(self._view, dtype=float).reshape(4, 4).T
        proj = np.array(self._proj, dtype=float).reshape(4, 4).T
        clip = proj @ view @ np.array([*xyz, 1.0])
        ndc = clip[:3] / clip[3]
        return float((ndc[0] + 1) / 2 * self.size), float((1 - ndc[1]) / 2 * self.size)

    def distractor_ok(self, x: float, y: float) -> bool:
        """Whether the distractor may stand at ``(x, y)``: on the table, clear of every
        region's marker (handle included) and inside the middle 84 % of the view."""
        d = self.look.distractor
        hx, hy = (h + self.look.table_extra for h in self.layout.half_extent)
        reach = d.radius + 0.022  # the handle
        if abs(x) > hx - reach or abs(y) > hy - reach:
            return False
        clear = REGION_SIDE / 2 + 0.006 + reach + 0.005
        cheb = np.max(np.abs(self.layout.centres - np.array([x, y])), axis=1)
        if np.any(cheb < clear):
            return False
        lo, hi = 0.08 * self.size, 0.92 * self.size
        for z in (0.0, d.height):
            col, row = self.project((x, y, z))
            if not (lo <= col <= hi and lo <= row <= hi):
                return False
        return True

    def move_distractor(self, rng: np.random.Generator, tries: int = 200) -> bool:
        """Put the distractor on a random spot where :meth:`distractor_ok` (uniform over
        the table, rejection sampling: ``tries`` draws of ``(x, y, yaw)`` at most) and
        return True; False (and it stays) when no draw fits."""
        d = self.look.distractor
        if d is None:
            raise ValueError("this look has no distractor")
        hx, hy = (h + self.look.table_extra for h in self.layout.half_extent)
        for _ in range(tries):
            x, y = rng.uniform(-hx, hx), rng.uniform(-hy, hy)
            yaw = rng.uniform(0.0, 2 * math.pi)
            if self.distractor_ok(x, y):
                self.distractor_spot = (float(x), float(y), float(yaw))
                self._put(self._mug, (x, y, d.height / 2), yaw)
                return True
        return False

    def distractor_step(self, rng: np.random.Generator, first: bool) -> bool:
        """Before a frame: the distractor moves on a recording's ``first`` frame, else with
        its probability (one uniform draw from ``rng``); returns whether it moved. Draws
        nothing without a distractor."""
        d = self.look.distractor
        if d is None:
            return False
        if first or rng.uniform() < d.move_prob:
            return self.move_distractor(rng)
        return False

    def snapshot(self) -> np.ndarray:
        """Render the current scene: uint8 array of shape (height, width, 3)."""
        p = self._p
        _, _, rgba, _, _ = p.getCameraImage(
            self.width, self.height, self._view, self._proj, renderer=p.ER_TINY_RENDERER,
            flags=p.ER_NO_SEGMENTATION_MASK, shadow=1,
            lightDirection=list(self.camera.light_direction), physicsClientId=self._cid)
        img = np.asarray(rgba, dtype=np.uint8).reshape(self.height, self.width, 4)
        return np.ascontiguousarray(img[:, :, :3])

    def render(self, arr: Arrangement) -> np.ndarray:
        """Pose the bodies as ``arr`` and render: uint8 array of shape (size, size, 3)."""
        self.pose(arr)
        return self.snapshot()

    def frame_seconds(self, frames: int) -> float:
        """Seconds per :meth:`snapshot` of the current pose, over ``frames`` renders (a
        baseline: the bare render cost of this scene)."""
        import time

        t0 = time.perf_counter()
        for _ in range(frames):
            self.snapshot()
        return (time.perf_counter() - t0) / frames

    def close(self) -> None:
        """Release the PyBullet connection (idempotent)."""
        if self._cid >= 0:
            self._p.disconnect(self._cid)
            self._cid = -1

    def __enter__(self) -> Scene:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def empty_scene_frame_seconds(size: int, frames: int) -> float:
    """Seconds per frame of a bare PyBullet tiny-renderer render of an empty scene (a
    baseline for ``vggc-cp bench generate``)."""
    import time

    p = import_pybullet()
    cid = p.connect(p.DIRECT)
    try:
        view = p.computeViewMatrix([0, -0.6, 0.6], [0, 0, 0], [0, 0, 1])
        proj = p.computeProjectionMatrixFOV(45.0, 1.0, 0.05, 5.0)
        t0 = time.perf_counter()
        for _ in range(frames):
            p.getCameraImage(size, size, view, proj, renderer=p.ER_TINY_RENDERER,
                             flags=p.ER_NO_SEGMENTATION_MASK, physicsClientId=cid)
        return (time.perf_counter() - t0) / frames
    finally:
        p.disconnect(cid)
