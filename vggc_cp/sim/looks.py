"""How a benchmark scene looks: the ``clean`` renderer, a ``randomized`` stand-in for
another renderer or a real camera, and a ``robot`` look that adds what a robot's own camera
sees.

``clean`` is the scene the learning defaults were tuned on: one table colour, fixed camera,
light and object appearance, no sensor noise. ``randomized`` varies every knob below, all
drawn from the trace's seed (same seed, same bytes), to test whether the defaults survive
scenes they were not tuned on:

* per trace (:func:`sample_look`): table colour (:data:`TABLE_TONES`) and a procedural table
  texture (:data:`TEXTURES`); region-marker colours (:data:`REGION_LIGHTNESS`,
  :data:`BORDER_LIGHTNESS`); camera pose (:data:`CAMERA_SHIFT`, :data:`CAMERA_TURN_DEG`);
  light direction (:data:`LIGHT_ELEVATION_DEG`, any azimuth);
* per object, once per trace (object identity is physical): its shape among its class's
  (:data:`CLASS_SHAPES`), its size (:data:`SIZE_SCALE`), its shade (:data:`SHADES`), and its
  placement noise (:data:`JITTER_SCALE` times the clean one, capped so that it stays in its
  region's cell, :data:`CELL_HALF`);
* per frame (:func:`finish_frame`): a global lighting gain (:data:`FRAME_GAIN`), a colour
  tint (:data:`FRAME_TINT`) and Gaussian sensor noise (:data:`NOISE_SIGMA`), in numpy after
  rendering.

``robot`` draws everything ``randomized`` draws, then (same per-trace stream, after those):

* a real arm model (:data:`ARM_MODEL`, the Franka Panda of ``pybullet_data``) behind the
  table's back edge, its hand resting above the region it last acted on (the renderer,
  :mod:`vggc_cp.sim.render`), holding the held object; the old fixed gripper is hidden;
* a slow lighting drift over the recording (:data:`DRIFT_AMPLITUDE`, :data:`DRIFT_PERIOD`,
  any phase), on top of the per-frame gain;
* a whole-pixel camera shake per frame (:data:`SHAKE_PX`);
* a distractor (:data:`DISTRACTOR_COLOURS`, :data:`DISTRACTOR_RADIUS`,
  :data:`DISTRACTOR_HEIGHT`) on the table outside every region (the table grows by
  :data:`ROBOT_TABLE_EXTRA`), moved to a new random spot before a frame with probability
  :data:`DISTRACTOR_MOVE` (drawn from the trace's per-frame stream).

``armless`` is the robot look with its arm hidden (:attr:`Look.arm_hidden`): the same
seed draws the same walk, look, drift, shake, mug and even the arm's rest regions, but the
renderer leaves the arm out and shows the fixed gripper instead, so a robot trace and its
armless twin differ only by the arm: what the arm costs a method is the difference of the
two (``vggc-cp robustness --looks robot,armless``).

Ground-truth states stay by class: an apple and a strawberry swapped are the same state.
Nothing here needs PyBullet.
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass, replace

import numpy as np

from vggc_cp.errors import lookup
from vggc_cp.sim.arrange import BLOCK_JITTER, FRUIT_JITTER
from vggc_cp.sim.dynamics import Benchmark

CLEAN = "clean"
RANDOMIZED = "randomized"
ROBOT = "robot"
ARMLESS = "armless"
#: Known looks (``vggc-cp generate --look``).
LOOKS = {CLEAN: "the renderer the defaults were tuned on (fixed colours, camera, light; "
                "no noise)",
         RANDOMIZED: "table colour and texture, markers, camera, light, object shapes, sizes "
                     "and shades drawn per trace; gain, tint and sensor noise per frame",
         ROBOT: "randomized, plus a Franka Panda arm resting above the region it last acted "
                "on (holding the held object), a slow lighting drift, a camera shake of up "
                "to 2 px per frame and a mug that moves between some frames",
         ARMLESS: "the robot look with its arm hidden: the same draws, drift, shake and mug, "
                  "the fixed gripper showing what is held (what the arm costs)"}

# ------------------------------------------------------------------ clean appearance
TABLE_RGBA = (0.62, 0.47, 0.32, 1.0)
REGION_RGBA = (0.22, 0.23, 0.26, 1.0)
BORDER_RGBA = (0.92, 0.92, 0.88, 1.0)
LIGHT_DIRECTION = (0.4, -0.6, 1.0)
#: Colour of each task class in the clean look.
CLASS_RGBA = {"red": (0.86, 0.08, 0.08, 1.0), "yellow": (0.97, 0.85, 0.12, 1.0),
              "block": (0.2, 0.55, 1.0, 1.0), "blue": (0.2, 0.55, 1.0, 1.0),
              "green": (0.16, 0.72, 0.24, 1.0)}

# ------------------------------------------------------------- randomized: per trace
#: Table tone families, each ``(darkest RGB, lightest RGB)``: a family is drawn uniformly,
#: then one lightness along it, then each channel moves by up to :data:`TABLE_CHANNEL`.
TABLE_TONES = {
    "wood": ((0.40, 0.25, 0.13), (0.76, 0.56, 0.37)),
    "grey": ((0.30, 0.30, 0.30), (0.78, 0.78, 0.78)),
    "felt": ((0.10, 0.26, 0.15), (0.24, 0.46, 0.30)),
    "linen": ((0.62, 0.58, 0.48), (0.88, 0.84, 0.72)),
    "slate": ((0.26, 0.30, 0.34), (0.50, 0.55, 0.60)),
}
TABLE_CHANNEL = 0.03
#: Table textures (drawn uniformly): ``grain`` wood-like wavy stripes, ``noise`` smooth
#: blotches, ``checker`` a cloth check with a fine weave. A texture multiplies the table
#: colour by 0.70-1.0 (:data:`TEXTURE_CONTRAST`).
TEXTURES = ("grain", "noise", "checker")
TEXTURE_CONTRAST = 0.30
#: Side (pixels) of the generated texture image.
TEXTURE_SIDE = 128
#: Lightness of the region markers' dark inner square and of their light border (grey,
#: each channel then moved by up to 0.03).
REGION_LIGHTNESS = (0.12, 0.34)
BORDER_LIGHTNESS = (0.78, 0.97)
#: Camera: the eye and target move together by up to this fraction of the view's width at
#: the target, per axis (0.03: about 2 pixels at 64 px) ...
CAMERA_SHIFT = 0.03
#: ... and the view turns by up to this many degrees in yaw, pitch and roll (each).
CAMERA_TURN_DEG = 1.0
#: Light: any azimuth, elevation in this range (degrees; clean: about 50).
LIGHT_ELEVATION_DEG = (35.0, 75.0)

# ------------------------------------------------------------ randomized: per object
#: The shapes of each task class; each object draws one, spread so that a class's objects
#: take different shapes where there are enough.
CLASS_SHAPES = {"red": ("apple", "strawberry", "tomato"),
                "yellow": ("lemon", "banana", "pear"),
                "block": ("cube",)}
#: Size scale of every object (fruit and cubes), uniform.
SIZE_SCALE = (0.85, 1.15)
#: Shade of each class, each channel uniform in ``(low RGB, high RGB)``: red stays red,
#: yellow yellow, a block blue.
SHADES = {"red": ((0.68, 0.02, 0.02), (0.95, 0.16, 0.14)),
          "yellow": ((0.88, 0.72, 0.04), (1.0, 0.92, 0.28)),
          "block": ((0.08, 0.38, 0.82), (0.32, 0.64, 1.0)),
          "blue": ((0.08, 0.38, 0.82), (0.32, 0.64, 1.0)),
          "green": ((0.06, 0.52, 0.12), (0.30, 0.82, 0.36))}
#: Placement noise (position, per axis) relative to the clean look's.
JITTER_SCALE = 1.3
#: A fruit's footprint plus its placement noise stays within this distance (m) of its
#: region's centre, per axis (regions are 0.16 m apart, markers 0.071 m half wide), so that
#: neighbours never touch; long fruit (banana, lemon) get less noise than round ones.
CELL_HALF = 0.076
#: Horizontal half-extent (m) of each fruit shape at scale 1 (stalks and stubs included).
FOOTPRINT = {"apple": 0.032, "strawberry": 0.034, "tomato": 0.036, "lemon": 0.051,
             "banana": 0.0585, "pear": 0.031, "cube": 0.036, "cylinder": 0.027, "brick": 0.041}

# ------------------------------------------------------------- randomized: per frame
#: Global lighting gain of a frame, uniform.
FRAME_GAIN = (0.85, 1.15)
#: Per-channel colour tint of a frame: each channel times 1 +- up to this.
FRAME_TINT = 0.04
#: Gaussian sensor noise, standard deviation in 0-255 units (then rounded and clipped).
NOISE_SIGMA = 4.0

# ------------------------------------------------------------------- robot look
#: The arm: a URDF of ``pybullet_data`` (installed with PyBullet, read from disk). Only the
#: Panda: the KUKA iiwa there has no gripper to hold an object with.
ARM_MODEL = "franka_panda/panda.urdf"
#: Lighting drift: the frame at index ``t`` is multiplied by
#: ``1 + A sin(2 pi t / T + phase)``, with ``A`` uniform in this range ...
DRIFT_AMPLITUDE = (0.05, 0.12)
#: ... and the period ``T`` uniform in this range times the number of frames of the
#: recording (the trace; the novel renders are a recording of their own); any phase.
DRIFT_PERIOD = (0.8, 1.5)
#: Camera shake: every frame is shifted by a whole number of pixels, ``dx`` and ``dy``
#: uniform in ``[-SHAKE_PX, SHAKE_PX]`` (edge pixels replicated).
SHAKE_PX = 2
#: The distractor (a mug: a cylinder with a dark opening and a handle): its colour, drawn
#: uniformly among these (none is a task class colour: red, yellow, blue, green) ...
DISTRACTOR_COLOURS = {"grey": (0.55, 0.56, 0.58), "brown": (0.42, 0.27, 0.16),
                      "white": (0.93, 0.93, 0.90), "purple": (0.45, 0.22, 0.55)}
#: ... its radius (m) and height (m), uniform ...
DISTRACTOR_RADIUS = (0.026, 0.034)
DISTRACTOR_HEIGHT = (0.07, 0.10)
#: ... and the probability, per frame after the first, that it moves to a new random spot on
#: the table outside every region (and inside the view).
DISTRACTOR_MOVE = 0.15
#: The robot look's table is this much (m) larger on every side than the layout's, so that
#: the distractor has room beside the regions (the camera is the layout's).
ROBOT_TABLE_EXTRA = 0.08


@dataclass(frozen=True)
class ObjectLook:
    """How one object (body) looks.

    Attributes
    ----------
    kind : str
        Shape: a fruit of :data:`CLASS_SHAPES` or ``"cube"``.
    scale : float
        Size relative to the clean shape.
    rgba : tuple of float
        Main colour.
    jitter : float
        Half-range (m, per axis) of its position noise on the table (a block: when it rests
        on a base region).
    """

    kind: str
    scale: float
    rgba: tuple[float, float, float, float]
    jitter: float


@dataclass(frozen=True)
class Distractor:
    """An object nobody acts on (a mug), standing on the table outside every region.

    Attributes
    ----------
    colour : str
        A name of :data:`DISTRACTOR_COLOURS`.
    rgba : tuple of float
    radius, height : float
        Of the mug's body (m).
    move_prob : float
        Probability, per frame after a recording's first, of a move to a new spot.
    """

    colour: str
    rgba: tuple[float, float, float, float]
    radius: float
    height: float
    move_prob: float


@dataclass(frozen=True)
class Look:
    """Every appearance knob of one trace (immutable); the clean look is :func:`clean_look`.

    Attributes
    ----------
    name : str
        ``"clean"`` or ``"randomized"``.
    table_rgba, region_rgba, border_rgba : tuple of float
        Table top, region marker (inner square) and marker border colours.
    table_texture : str or None
        One of :data:`TEXTURES`, or None (plain colour).
    texture_seed : int
        Seeds the texture image (:func:`texture_image`).
    camera_shift : tuple of float
        Move of eye and target (x, y, z), as fractions of the view's width at the target.
    camera_turn : tuple of float
        Yaw, pitch and roll of the view (degrees) about the target.
    light_direction : tuple of float
    objects : tuple of ObjectLook
        One per body, in body order.
    frame_gain : tuple of float
        Per-frame gain range ``(1, 1)``: none.
    frame_tint : float
        Per-frame half-range of the channel tint (0: none).
    noise_sigma : float
        Per-frame Gaussian noise (0-255 units; 0: none).
    arm : str or None
        The arm's URDF under ``pybullet_data`` (:data:`ARM_MODEL`), or None (the old fixed
        gripper).
    arm_hidden : bool
        The arm is drawn (where it rests, from the same streams) but not rendered: the
        fixed gripper stands in for it (the ``armless`` look).
    drift : tuple of float
        Lighting drift ``(amplitude, period in frames, phase in radians)``
        (:meth:`drift_gain`).
    shake_px : int
        Largest whole-pixel camera shake per frame and axis (0: none).
    distractor : Distractor or None
    table_extra : float
        How much larger (m) the table is on every side than the layout's.
    """

    name: str
    table_rgba: tuple[float, float, float, float]
    region_rgba: tuple[float, float, float, float]
    border_rgba: tuple[float, float, float, float]
    table_texture: str | None
    texture_seed: int
    camera_shift: tuple[float, float, float]
    camera_turn: tuple[float, float, float]
    light_direction: tuple[float, float, float]
    objects: tuple[ObjectLook, ...]
    frame_gain: tuple[float, float]
    frame_tint: float
    noise_sigma: float
    arm: str | None = None
    arm_hidden: bool = False
    drift: tuple[float, float, float] = (0.0, 1.0, 0.0)
    shake_px: int = 0
    distractor: Distractor | None = None
    table_extra: float = 0.0

    @property
    def is_clean(self) -> bool:
        return self.name == CLEAN

    def drift_gain(self, t: int) -> float:
        """The lighting drift's gain at frame ``t`` (1 without drift)."""
        amp, period, phase = self.drift
        return 1.0 + amp * math.sin(2 * math.pi * t / period + phase)

    @property
    def placement_jitter(self) -> tuple[float, ...] | None:
        """Per-body table position noise for :mod:`vggc_cp.sim.arrange` (None: the clean
        constants)."""
        return None if self.is_clean else tuple(o.jitter for o in self.objects)

    def as_meta(self) -> dict:
        """JSON-friendly per-trace values (for a trace's ``meta``)."""
        r = lambda v: round(float(v), 4)  # noqa: E731
        rs = lambda vs: [r(v) for v in vs]  # noqa: E731
        return {
            "table_rgba": rs(self.table_rgba[:3]),
            "table_texture": self.table_texture,
            "region_rgba": rs(self.region_rgba[:3]),
            "border_rgba": rs(self.border_rgba[:3]),
            "camera_shift": rs(self.camera_shift),
            "camera_turn_deg": rs(self.camera_turn),
            "light_direction": rs(self.light_direction),
            "objects": [{"kind": o.kind, "scale": r(o.scale), "rgb": rs(o.rgba[:3]),
                         "jitter_m": r(o.jitter)} for o in self.objects],
            "frame_gain": rs(self.frame_gain),
            "frame_tint": r(self.frame_tint),
            "noise_sigma": r(self.noise_sigma),
        } | ({} if self.arm is None else self._robot_meta())

    def _robot_meta(self) -> dict:
        r = lambda v: round(float(v), 4)  # noqa: E731
        d = self.distractor
        out = {"arm": self.arm} | ({"arm_hidden": True} if self.arm_hidden else {}) | {
            "drift": {"amplitude": r(self.drift[0]), "period_frames": r(self.drift[1]),
                      "phase": r(self.drift[2])},
            "shake_px": int(self.shake_px),
            "table_extra_m": r(self.table_extra)}
        if d is not None:
            out["distractor"] = {"kind": "mug", "colour": d.colour,
                                 "rgb": [r(c) for c in d.rgba[:3]], "radius_m": r(d.radius),
                                 "height_m": r(d.height), "move_prob": r(d.move_prob)}
        return out


def check_look(name: str) -> str:
    """``name`` if it is a known look; else raise :class:`~vggc_cp.errors.VggcError` listing
    the known ones."""
    lookup(LOOKS, name, "look")
    return name


def _classes(bench: Benchmark) -> list[str]:
    spec = bench.spec
    return ["block" if bench.blocks else spec.object_class(i) for i in range(spec.m)]


def clean_look(bench: Benchmark) -> Look:
    """The clean look of ``bench`` (today's renderer)."""
    objects = tuple(
        ObjectLook(kind, 1.0, CLASS_RGBA[cls], BLOCK_JITTER if bench.stacking else FRUIT_JITTER)
        for kind, cls in zip(bench.spec.objects, _classes(bench)))
    return Look(CLEAN, TABLE_RGBA, REGION_RGBA, BORDER_RGBA, None, 0, (0.0, 0.0, 0.0),
                (0.0, 0.0, 0.0), LIGHT_DIRECTION, objects, (1.0, 1.0), 0.0, 0.0)


def _grey(rng: np.random.Generator, lo_hi: tuple[float, float]) -> tuple[float, ...]:
    g = rng.uniform(*lo_hi)
    rgb = np.clip(g + rng.uniform(-0.03, 0.03, 3), 0.0, 1.0)
    return (*(float(c) for c in rgb), 1.0)


def sample_look(rng: np.random.Generator, bench: Benchmark) -> Look:
    """Draw a randomized look for ``bench`` (per-trace and per-object values; the per-frame
    ranges are stored and drawn by :func:`finish_frame`)."""
    families = sorted(TABLE_TONES)
    lo, hi = (np.array(v) for v in TABLE_TONES[families[int(rng.integers(len(families)))]])
    table = np.clip(lo + rng.uniform() * (hi - lo) + rng.uniform(-TABLE_CHANNEL, TABLE_CHANNEL, 3),
                    0.0, 1.0)
    texture = TEXTURES[int(rng.integers(len(TEXTURES)))]
    texture_seed = int(rng.integers(2 ** 31))
    region = _grey(rng, REGION_LIGHTNESS)
    border = _grey(rng, BORDER_LIGHTNESS)
    shift = rng.uniform(-CAMERA_SHIFT, CAMERA_SHIFT, 3)
    turn = rng.uniform(-CAMERA_TURN_DEG, CAMERA_TURN_DEG, 3)
    az = rng.uniform(0.0, 2 * math.pi)
    el = math.radians(rng.uniform(*LIGHT_ELEVATION_DEG))
    light = (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))
    classes = _classes(bench)
    kinds: list[str] = [""] * len(classes)
    # a task beyond the seven names its objects' shapes; the seven draw them per class
    for cls in sorted(set(classes)) if bench.spec.object_classes is None else ():
        bodies = [i for i, c in enumerate(classes) if c == cls]
        shapes = CLASS_SHAPES[cls]
        pool: list[str] = []
        while len(pool) < len(bodies):  # every shape once before any twice
            pool += [shapes[j] for j in rng.permutation(len(shapes))]
        for i, kind in zip(bodies, pool):
            kinds[i] = kind
    if bench.spec.object_classes is not None:
        kinds = list(bench.spec.objects)
    objects = []
    for kind, cls in zip(kinds, classes):
        scale = float(rng.uniform(*SIZE_SCALE))
        lo_s, hi_s = (np.array(v) for v in SHADES[cls])
        rgb = lo_s + rng.uniform(0.0, 1.0, 3) * (hi_s - lo_s)
        if bench.stacking:
            jitter = JITTER_SCALE * BLOCK_JITTER
        else:
            jitter = min(JITTER_SCALE * FRUIT_JITTER, max(0.0, CELL_HALF - FOOTPRINT[kind] * scale))
        objects.append(ObjectLook(kind, scale, (*(float(c) for c in rgb), 1.0), float(jitter)))
    return Look(RANDOMIZED, (*(float(c) for c in table), 1.0), region, border, texture,
                texture_seed, tuple(float(v) for v in shift), tuple(float(v) for v in turn),
                light, tuple(objects), FRAME_GAIN, FRAME_TINT, NOISE_SIGMA)


def sample_robot_look(rng: np.random.Generator, bench: Benchmark, n_frames: int) -> Look:
    """Draw a robot look: :func:`sample_look`'s draws, then (from the same ``rng``) the
    drift's amplitude, period (times ``n_frames``, the recording's length) and phase, and
    the distractor's colour, radius and height."""
    base = sample_look(rng, bench)
    amp = float(rng.uniform(*DRIFT_AMPLITUDE))
    period = float(rng.uniform(*DRIFT_PERIOD)) * max(int(n_frames), 1)
    phase = float(rng.uniform(0.0, 2 * math.pi))
    names = sorted(DISTRACTOR_COLOURS)
    colour = names[int(rng.integers(len(names)))]
    radius = float(rng.uniform(*DISTRACTOR_RADIUS))
    height = float(rng.uniform(*DISTRACTOR_HEIGHT))
    mug = Distractor(colour, (*DISTRACTOR_COLOURS[colour], 1.0), radius, height,
                     DISTRACTOR_MOVE)
    return replace(base, name=ROBOT, arm=ARM_MODEL, drift=(amp, period, phase),
                   shake_px=SHAKE_PX, distractor=mug, table_extra=ROBOT_TABLE_EXTRA)


def make_look(name: str, bench: Benchmark, rng: np.random.Generator,
              n_frames: int = 1) -> Look:
    """The look called ``name`` for ``bench`` (``rng`` is used by ``randomized``, ``robot``
    and ``armless``; ``n_frames``, the trace's number of observations, by the last two: the
    drift's period is a multiple of it)."""
    check_look(name)
    if name == CLEAN:
        return clean_look(bench)
    if name == ROBOT:
        return sample_robot_look(rng, bench, n_frames)
    if name == ARMLESS:
        return replace(sample_robot_look(rng, bench, n_frames), name=ARMLESS, arm_hidden=True)
    return sample_look(rng, bench)


def shift_image(img: np.ndarray, dx: int, dy: int) -> np.ndarray:
    """``img`` (H, W, C) moved ``dx`` pixels right and ``dy`` down, edge pixels replicated."""
    h, w = img.shape[:2]
    rows = np.clip(np.arange(h) - dy, 0, h - 1)
    cols = np.clip(np.arange(w) - dx, 0, w - 1)
    return img[rows][:, cols]


def finish_frame(img: np.ndarray, look: Look, rng: np.random.Generator,
                 t: int = 0) -> np.ndarray:
    """Apply the per-frame effects of ``look`` to a rendered uint8 frame: gain and tint,
    then (robot look) the camera shake and the lighting drift at frame ``t``, then sensor
    noise. The clean look returns ``img`` untouched and draws nothing; the randomized look
    ignores ``t`` and draws exactly what it always drew."""
    if look.is_clean:
        return img
    gain = rng.uniform(*look.frame_gain)
    tint = 1.0 + rng.uniform(-look.frame_tint, look.frame_tint, 3)
    if look.shake_px > 0:
        dx, dy = (int(v) for v in rng.integers(-look.shake_px, look.shake_px + 1, 2))
        img = shift_image(img, dx, dy)
    if look.drift[0] != 0.0:
        gain = gain * look.drift_gain(t)
    noise = rng.standard_normal(img.shape, dtype=np.float32)
    out = img * (gain * tint).astype(np.float32) + np.float32(look.noise_sigma) * noise
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


# ---------------------------------------------------------------------- textures
def _smooth_noise(rng: np.random.Generator, side: int, cells: int) -> np.ndarray:
    """Bilinearly interpolated random grid (values 0..1), tileable, shape (side, side)."""
    grid = rng.uniform(0.0, 1.0, (cells, cells))
    t = np.arange(side) * cells / side
    i0 = np.floor(t).astype(int)
    f = t - i0
    f = f * f * (3 - 2 * f)
    i1 = (i0 + 1) % cells
    rows = grid[i0] * (1 - f)[:, None] + grid[i1] * f[:, None]
    return rows[:, i0] * (1 - f)[None, :] + rows[:, i1] * f[None, :]


def texture_image(kind: str, seed: int, side: int = TEXTURE_SIDE) -> np.ndarray:
    """A grey texture (uint8, shape (side, side, 3)) that multiplies the table colour by
    ``1 - TEXTURE_CONTRAST`` .. 1."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:side, 0:side] / side
    if kind == "grain":
        warp = _smooth_noise(rng, side, 4) * rng.uniform(0.6, 1.4)
        stripes = rng.uniform(6.0, 14.0)
        v = 0.5 + 0.5 * np.sin(2 * np.pi * (stripes * yy + warp + 0.15 * xx))
        v = 0.75 * v ** 2 + 0.25 * _smooth_noise(rng, side, 16)
    elif kind == "noise":
        v = 0.65 * _smooth_noise(rng, side, 6) + 0.35 * _smooth_noise(rng, side, 16)
    elif kind == "checker":
        cells = int(rng.integers(4, 11))
        check = ((np.floor(yy * cells) + np.floor(xx * cells)) % 2)
        weave = 0.5 + 0.5 * np.sin(2 * np.pi * side / 4 * xx) * np.sin(2 * np.pi * side / 4 * yy)
        v = 0.8 * check + 0.2 * weave
    else:
        raise ValueError(f"unknown texture {kind!r}")
    v = (v - v.min()) / max(float(v.max() - v.min()), 1e-9)
    grey = np.rint(255 * (1.0 - TEXTURE_CONTRAST + TEXTURE_CONTRAST * v)).astype(np.uint8)
    return np.repeat(grey[:, :, None], 3, axis=2)


def png_bytes(img: np.ndarray) -> bytes:
    """A minimal RGB PNG of a uint8 array (H, W, 3); deterministic bytes."""
    h, w, _ = img.shape
    raw = b"".join(b"\x00" + np.ascontiguousarray(img[i]).tobytes() for i in range(h))

    def chunk(tag: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
