"""Triangle meshes of the fruit that are not PyBullet primitives (:mod:`vggc_cp.sim.render`
builds the bodies from them): vertices in metres about the body's origin, and vertex
indices, three per triangle."""

from __future__ import annotations

import math


def ellipsoid(a: float, b: float, c: float, nu: int = 14, nv: int = 9
              ) -> tuple[list[list[float]], list[int]]:
    """An ellipsoid of semi-axes ``a``, ``b``, ``c`` (m) about the origin: ``nv + 1`` rings
    of ``nu`` vertices from pole to pole, and the triangles joining neighbouring rings
    (vertex indices, three per triangle), as ``p.createVisualShape(GEOM_MESH, vertices=...,
    indices=...)`` takes them.

    >>> verts, idx = ellipsoid(0.03, 0.03, 0.02, nu=4, nv=2)
    >>> len(verts), len(idx) // 3
    (12, 16)
    """
    verts, idx = [], []
    for i in range(nv + 1):
        th = math.pi * i / nv
        for j in range(nu):
            ph = 2 * math.pi * j / nu
            verts.append([a * math.sin(th) * math.cos(ph), b * math.sin(th) * math.sin(ph),
                          c * math.cos(th)])
    for i in range(nv):
        for j in range(nu):
            a0, a1 = i * nu + j, i * nu + (j + 1) % nu
            idx += [a0, a0 + nu, a1, a1, a0 + nu, a1 + nu]
    return verts, idx


def strawberry(radius: float, top: float, bottom: float, nu: int = 14, nv: int = 8
               ) -> tuple[list[list[float]], list[int]]:
    """A cone-like body: a rounded shoulder at ``top`` tapering to a blunt tip at ``bottom``
    (heights in m, ``radius`` the shoulder's): a vertex above the top, ``nv`` rings of ``nu``
    vertices, one at the tip, and the triangles between them (as :func:`ellipsoid`).

    >>> verts, idx = strawberry(0.034, 0.012, -0.036, nu=4, nv=2)
    >>> len(verts), len(idx) // 3
    (10, 16)
    """
    verts, idx = [[0.0, 0.0, top + 0.2 * radius]], []
    rings = []
    for i in range(1, nv + 1):
        t = i / nv  # 0 at the top, 1 at the tip
        z = top - (top - bottom) * t
        rad = radius * (math.sin(math.pi / 2 * min(1.0, 3 * t)) * (1 - 0.85 * t ** 1.3))
        ring = []
        for j in range(nu):
            ph = 2 * math.pi * j / nu
            ring.append(len(verts))
            verts.append([rad * math.cos(ph), rad * math.sin(ph), z])
        rings.append(ring)
    for j in range(nu):
        idx += [0, rings[0][j], rings[0][(j + 1) % nu]]
    for r0, r1 in zip(rings[:-1], rings[1:]):
        for j in range(nu):
            k = (j + 1) % nu
            idx += [r0[j], r1[j], r0[k], r0[k], r1[j], r1[k]]
    tip = len(verts)
    verts.append([0.0, 0.0, bottom - 0.004])
    for j in range(nu):
        idx += [rings[-1][j], tip, rings[-1][(j + 1) % nu]]
    return verts, idx
