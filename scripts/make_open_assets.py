#!/usr/bin/env python3
"""Writes the open, multi-shell test assets of examples/meshes/ from meshes already there plus
generated parts, byte for byte (binary little-endian PLY, compressed with xz -9 where named .xz):

  devil_hair.ply.xz  mannequin_devil.ply (an open head) + two eyeballs (closed spheres, separate
                     shells in front of the eyelids) + 12 hair cards (open sheets, a separate
                     shell each) hanging down the back of the head, as game characters have them
  man_cape.ply.xz    man.ply.xz (a closed figure) + a cape (one open, folded cloth sheet) behind
                     the back + a collar (a closed torus, a separate shell) around the neck
  card.ply           a single card, 4 x 1.5 units in 160 x 60 quads (a cloth or a hair card)

The generated parts are placed from the base meshes' vertex data, clear of their surfaces.
Usage: python3 scripts/make_open_assets.py"""
import lzma, math, os, struct

here = os.path.dirname(os.path.abspath(__file__))
meshes = os.path.join(here, "..", "examples", "meshes")


def read_ply(path):
    data = lzma.open(path).read() if path.endswith(".xz") else open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    nv = nf = 0
    for line in data[:end].decode().split("\n"):
        p = line.split()
        if p[:2] == ["element", "vertex"]:
            nv = int(p[2])
        if p[:2] == ["element", "face"]:
            nf = int(p[2])
    V = [struct.unpack_from("<3f", data, end + 12 * i) for i in range(nv)]
    pos, F = end + 12 * nv, []
    for _ in range(nf):
        n = data[pos]
        F.append(list(struct.unpack_from("<%di" % n, data, pos + 1)))
        pos += 1 + 4 * n
    return V, F


def write_ply(path, V, F, comment):
    head = ("ply\nformat binary_little_endian 1.0\ncomment %s\nelement vertex %d\n"
            "property float x\nproperty float y\nproperty float z\nelement face %d\n"
            "property list uchar int vertex_indices\nend_header\n" % (comment, len(V), len(F)))
    body = bytearray(head.encode())
    for v in V:
        body += struct.pack("<3f", *v)
    for f in F:
        body += struct.pack("<B%di" % len(f), len(f), *f)
    if path.endswith(".xz"):
        body = lzma.compress(bytes(body), preset=9, check=lzma.CHECK_CRC64)
    with open(path, "wb") as out:
        out.write(body)


def grid_sheet(V, F, point, nu, nv):
    """Appends the quads of point(a, b), a, b in [0, 1], nu x nv of them, as triangles facing
    along d point / da x d point / db."""
    base = len(V)
    for j in range(nv + 1):
        for i in range(nu + 1):
            V.append(point(i / nu, j / nv))
    for j in range(nv):
        for i in range(nu):
            a = base + j * (nu + 1) + i
            F.append([a, a + 1, a + nu + 2])
            F.append([a, a + nu + 2, a + nu + 1])


def sphere(V, F, centre, r, n=16):
    """A closed UV sphere facing outwards: poles on z."""
    base = len(V)
    V.append((centre[0], centre[1], centre[2] + r))
    for i in range(1, n):
        t = math.pi * i / n
        for k in range(2 * n):
            p = 2 * math.pi * k / (2 * n)
            V.append((centre[0] + r * math.sin(t) * math.cos(p), centre[1] + r * math.sin(t) * math.sin(p),
                      centre[2] + r * math.cos(t)))
    V.append((centre[0], centre[1], centre[2] - r))
    ring = lambda i, k: base + 1 + (i - 1) * 2 * n + k % (2 * n)
    for k in range(2 * n):
        F.append([base, ring(1, k), ring(1, k + 1)])
    for i in range(1, n - 1):
        for k in range(2 * n):
            F.append([ring(i, k), ring(i + 1, k), ring(i + 1, k + 1)])
            F.append([ring(i, k), ring(i + 1, k + 1), ring(i, k + 1)])
    south = len(V) - 1
    for k in range(2 * n):
        F.append([south, ring(n - 1, k + 1), ring(n - 1, k)])


def torus(V, F, centre, rx, ry, r, n=48, m=12):
    """A closed torus about z with an elliptic core (rx, ry) and tube radius r, facing outwards."""
    base = len(V)
    for i in range(n):
        a = 2 * math.pi * i / n
        cx, cy = math.cos(a), math.sin(a)
        # the core's outward normal in the plane
        nx, ny = cx / rx, cy / ry
        ln = math.hypot(nx, ny)
        nx, ny = nx / ln, ny / ln
        for k in range(m):
            b = 2 * math.pi * k / m
            V.append((centre[0] + rx * cx + r * math.cos(b) * nx, centre[1] + ry * cy + r * math.cos(b) * ny,
                      centre[2] + r * math.sin(b)))
    at = lambda i, k: base + (i % n) * m + k % m
    for i in range(n):
        for k in range(m):
            F.append([at(i, k), at(i + 1, k), at(i + 1, k + 1)])
            F.append([at(i, k), at(i + 1, k + 1), at(i, k + 1)])


def devil_hair():
    V, F = read_ply(os.path.join(meshes, "mannequin_devil.ply"))
    V, F = list(V), list(F)
    head = list(V)
    # Eyeballs: the face looks along -y; each eyelid's front-most point near (+-4.4, z 6.4).
    for side in (-1, 1):
        near = [v for v in head if abs(v[0] - side * 4.4) < 0.8 and abs(v[2] - 6.4) < 0.8]
        front = min(v[1] for v in near)
        sphere(V, F, (side * 4.4, front + 1.0, 6.4), 1.35)
    # Hair cards: 12 around the back of the head (angle from +y within +-60 degrees), each from
    # z = 14 down 12 units, 2.4 wide, 1 unit clear of the widest part of the head behind it
    # and flaring out by 2 units at its tip.
    for c in range(12):
        t = math.radians(-60 + 120 * c / 11)
        d = (math.sin(t), math.cos(t))
        wide = max(v[0] * d[0] + v[1] * d[1] for v in head
                   if 1.5 < v[2] < 14.5 and abs(v[0] * d[1] - v[1] * d[0]) < 1.5)
        side = (d[1], -d[0])

        def point(a, b, t=t, d=d, side=side, wide=wide):
            r = wide + 1.0 + 2.0 * b * b
            u = (a - 0.5) * 2.4
            return (r * d[0] + u * side[0], r * d[1] + u * side[1], 14.0 - 12.0 * b)

        grid_sheet(V, F, point, 4, 24)
    write_ply(os.path.join(meshes, "devil_hair.ply.xz"), V, F,
              "made by raywarp: python3 scripts/make_open_assets.py, from mannequin_devil.ply")


def man_cape():
    V, F = read_ply(os.path.join(meshes, "man.ply.xz"))
    V, F = list(V), list(F)
    body = list(V)
    # The cape: from the shoulders (z 0.30) down to z -0.10 behind the back (the figure looks
    # along -y), 0.015 clear of the back at its widest, flaring 0.05 backwards and 0.04 to the
    # sides at the hem, with four folds across.
    back = max(v[1] for v in body if abs(v[0]) < 0.16 and -0.12 < v[2] < 0.31)
    torso = [v[0] for v in body if abs(v[0]) < 0.12 and 0.1 < v[2] < 0.3]
    mid = sum(torso) / len(torso)

    def point(a, b):
        half = 0.10 + 0.04 * b
        y = back + 0.015 + 0.05 * b + 0.008 * (1 + math.sin(8 * math.pi * a)) * b
        return (mid + (a - 0.5) * 2 * half, y, 0.30 - 0.40 * b)

    grid_sheet(V, F, point, 64, 48)
    # The collar: a torus around the neck at z 0.39, 0.006 clear of it.
    ring = [v for v in body if abs(v[2] - 0.39) < 0.004 and abs(v[0]) < 0.05]
    cx = (min(v[0] for v in ring) + max(v[0] for v in ring)) / 2
    cy = (min(v[1] for v in ring) + max(v[1] for v in ring)) / 2
    rx = max(abs(v[0] - cx) for v in ring) + 0.012
    ry = max(abs(v[1] - cy) for v in ring) + 0.012
    torus(V, F, (cx, cy, 0.39), rx, ry, 0.006)
    write_ply(os.path.join(meshes, "man_cape.ply.xz"), V, F,
              "made by raywarp: python3 scripts/make_open_assets.py, from man.ply.xz")


def card():
    V, F = [], []
    grid_sheet(V, F, lambda a, b: (-1.5 + 4.0 * a, 11.0, -0.75 + 1.5 * b), 160, 60)
    write_ply(os.path.join(meshes, "card.ply"), V, F,
              "made by raywarp: python3 scripts/make_open_assets.py")


if __name__ == "__main__":
    devil_hair()
    man_cape()
    card()
