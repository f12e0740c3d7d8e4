#!/usr/bin/env python3
"""Writes the bundled meshes of resources/meshes/ (deterministic; rerun to regenerate).

- ring.obj: a torus (major radius 6 cm, tube radius 1.5 cm), centred at its centre of mass with
  its axis along z: non-convex and not simply connected (genus 1). Used by horseshoe.xml.
- bracket.stl: an L-shaped bracket (binary STL), 8 x 4 x 6 cm outside, 1.5 cm thick walls:
  non-convex with sharp feature edges. Used by mesh_drop.xml.
"""
import math
import pathlib
import struct

OUT = pathlib.Path(__file__).resolve().parents[1] / "resources" / "meshes"


def ring(path, R=0.06, r=0.015, nu=24, nv=10):
    verts, tris = [], []
    for i in range(nu):
        u = 2 * math.pi * i / nu
        for j in range(nv):
            v = 2 * math.pi * j / nv
            verts.append(((R + r * math.cos(v)) * math.cos(u), (R + r * math.cos(v)) * math.sin(u), r * math.sin(v)))
    idx = lambda i, j: (i % nu) * nv + (j % nv)
    for i in range(nu):
        for j in range(nv):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            # Counter-clockwise seen from outside: (u, v) runs with the outward normal.
            tris += [(a, b, c), (a, c, d)]
    with open(path, "w") as f:
        f.write("# ring: torus R = 0.06 m, r = 0.015 m (scripts/make_meshes.py)\n")
        for x, y, z in verts:
            f.write(f"v {x:.9f} {y:.9f} {z:.9f}\n")
        for a, b, c in tris:
            f.write(f"f {a + 1} {b + 1} {c + 1}\n")


def bracket(path):
    # L profile in the xz plane (counter-clockwise), extruded along y from -0.02 to 0.02.
    prof = [(-0.04, -0.03), (0.04, -0.03), (0.04, -0.015), (-0.025, -0.015), (-0.025, 0.03), (-0.04, 0.03)]
    y0, y1 = -0.02, 0.02
    n = len(prof)
    # Vertices: front (y = y0) 0..n-1, back (y = y1) n..2n-1.
    verts = [(x, y0, z) for x, z in prof] + [(x, y1, z) for x, z in prof]
    tris = []
    # Caps: the L as four triangles. Seen from -y (the front cap's outside) the profile, which
    # runs counter-clockwise in the (x, z) plane, is counter-clockwise too: (x, z) seen from -y
    # keeps its handedness because y = z × x. The back cap is reversed.
    cap = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5)]
    for a, b, c in cap:
        tris.append((a, b, c))
        tris.append((a + n, c + n, b + n))
    for k in range(n):
        a, b = k, (k + 1) % n
        tris += [(a, b + n, b), (a, a + n, b + n)]
    with open(path, "wb") as f:
        f.write(b"bracket: L-shaped, scripts/make_meshes.py".ljust(80, b" "))
        f.write(struct.pack("<I", len(tris)))
        for t in tris:
            p = [verts[i] for i in t]
            e1 = [p[1][k] - p[0][k] for k in range(3)]
            e2 = [p[2][k] - p[0][k] for k in range(3)]
            nrm = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
            l = math.sqrt(sum(x * x for x in nrm))
            f.write(struct.pack("<3f", *[x / l for x in nrm]))
            for q in p:
                f.write(struct.pack("<3f", *q))
            f.write(struct.pack("<H", 0))


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    ring(OUT / "ring.obj")
    bracket(OUT / "bracket.stl")
    print("wrote", OUT / "ring.obj", OUT / "bracket.stl")
