#!/usr/bin/env python3
"""Writes bunny_nod_0000.ply.xz ... : copies of ../meshes/bunny.ply whose head nods back and
forth, a deformation authored outside raywarp (a smooth bend about the neck, here in plain
Python), for examples/bunny_sequence.json. Every copy keeps the mesh's vertices in the same order
and its faces. Run from anywhere: python3 examples/sequence/make_bunny_nod.py"""
import lzma
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))
FRAMES = 9
NOD_DEG = 22.0  # the largest tilt of the head
PIVOT = (-0.5, 4.6)  # (x, y) of the neck, about which the head turns (about the z axis)
NECK, HEAD = 4.6, 7.6  # the turn grows smoothly from height NECK to its full value at HEAD


def read_ascii_ply(path):
    with open(path) as f:
        lines = f.read().split("\n")
    end = lines.index("end_header")
    header = lines[: end + 1]
    count = next(int(l.split()[2]) for l in header if l.startswith("element vertex"))
    vertices = [list(map(float, l.split())) for l in lines[end + 1 : end + 1 + count]]
    rest = [l for l in lines[end + 1 + count :] if l.strip()]
    return header, vertices, rest


def smoothstep(t):
    t = min(max(t, 0.0), 1.0)
    return t * t * (3.0 - 2.0 * t)


def nod(v, degrees):
    x, y, z = v
    a = math.radians(degrees) * smoothstep((y - NECK) / (HEAD - NECK))
    dx, dy = x - PIVOT[0], y - PIVOT[1]
    c, s = math.cos(a), math.sin(a)
    return (PIVOT[0] + c * dx - s * dy, PIVOT[1] + s * dx + c * dy, z)


def main():
    header, vertices, faces = read_ascii_ply(os.path.join(HERE, "..", "meshes", "bunny.ply"))
    header = [l for l in header if not l.startswith("comment")]
    header.insert(2, "comment the head of ../meshes/bunny.ply nodding (make_bunny_nod.py)")
    for k in range(FRAMES):
        degrees = NOD_DEG * math.sin(2.0 * math.pi * k / (FRAMES - 1))
        lines = header[:]
        lines += ["%.6f %.6f %.6f" % nod(v, degrees) for v in vertices]
        lines += faces
        name = os.path.join(HERE, "bunny_nod_%04d.ply.xz" % k)
        with lzma.open(name, "wt", preset=9) as f:
            f.write("\n".join(lines) + "\n")
        print("wrote", name, "(tilt %.1f degrees)" % degrees)


if __name__ == "__main__":
    main()
