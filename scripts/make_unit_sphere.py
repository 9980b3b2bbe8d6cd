#!/usr/bin/env python3
"""Writes data/sphere/unit_sphere.obj: an icosahedron subdivided 4 times (2562 vertices,
5120 triangles), every vertex on the unit sphere, normals exact, counter-clockwise outward.

At a radius of 230 px (the wax-sphere photographs) its silhouette deviates from the circle by
at most 0.14 px. Run from the repository root: python3 scripts/make_unit_sphere.py
"""
import math

SUBDIVISIONS = 4


def normalise(p):
    length = math.sqrt(sum(c * c for c in p))
    return tuple(c / length for c in p)


def main():
    t = (1 + 5**0.5) / 2
    vertices = [normalise(p) for p in [
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
        (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(SUBDIVISIONS):
        midpoints = {}

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in midpoints:
                vertices.append(normalise(tuple((vertices[a][i] + vertices[b][i]) / 2
                                                for i in range(3))))
                midpoints[key] = len(vertices) - 1
            return midpoints[key]

        faces = [face
                 for a, b, c in faces
                 for ab, bc, ca in [(midpoint(a, b), midpoint(b, c), midpoint(c, a))]
                 for face in [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]]
    with open("data/sphere/unit_sphere.obj", "w") as out:
        out.write("# Unit sphere for cdrf: an icosahedron subdivided %d times, vertices on the unit\n"
                  "# sphere, exact normals. Written by scripts/make_unit_sphere.py. Scale it with\n"
                  "# mm_per_unit (35 for the r = 35 mm wax sphere).\n" % SUBDIVISIONS)
        out.write("# %d vertices, %d triangles\n" % (len(vertices), len(faces)))
        for p in vertices:
            out.write("v %.7f %.7f %.7f\n" % p)
        for p in vertices:
            out.write("vn %.7f %.7f %.7f\n" % p)
        for a, b, c in faces:
            out.write("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1))


if __name__ == "__main__":
    main()
