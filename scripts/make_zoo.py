#!/usr/bin/env python3
"""Writes examples/zoo/: a twist, a bend, a box cut and an incision on each test mesh, at
raywarp's default settings (only the box, the deformer and the camera are given). The boxes go
through each mesh's thin parts (legs, fingers, ears, horns, teeth); they were placed from the
meshes' vertex data. Usage: python3 scripts/make_zoo.py"""
import json, math, os

here = os.path.dirname(os.path.abspath(__file__))
out = os.path.join(here, "..", "examples", "zoo")
AX = "xyz"

# name, mesh, closed, box (centre, half extents, rotation_deg), twist axis (local), twist angle,
# camera (eye, target, up, fov_y_deg), what the box holds
MESHES = [
    ("camel", "camel.ply", True, ([0, -0.2975, -0.18], [0.165, 0.1975, 0.34], [0, 0, 180]), 1, 180,
     ([2.0, 0.25, 1.1], [0, -0.2, 0], [0, 1, 0], 30), "the four lower legs"),
    ("devil", "mannequin_devil.ply", False, ([0, 0, 7.75], [13, 17, 12.75], [0, 0, 0]), 2, 90,
     ([8, -75, 6], [0, 0, 4], [0, 0, 1], 36), "the open head from the neck: ears, horns, fangs"),
    ("man_hand", "man.ply.xz", True,
     ([-0.1875, 0.0325, -0.0275], [0.0325, 0.0375, 0.0675], [180, 0, 0]), 2, 90,
     ([-0.55, -0.45, 0], [-0.1875, 0.0325, -0.0275], [0, 0, 1], 20), "one hand's fingers"),
    ("armadillo_hand", "armadillo.ply.xz", True, ([49.5, 68, -22.5], [16.5, 25, 37.5], [0, 0, 0]),
     0, 120, ([60, 40, -330], [40, 55, 0], [0, 1, 0], 25), "a raised hand with fingers and claws"),
    ("horse_legs", "horse.ply.xz", True, ([0.014, -0.014, -0.051], [0.029, 0.079, 0.0265], [180, 0, 0]),
     2, 90, ([0.4, 0.05, 0.0], [0.015, 0, -0.02], [0, 0, 1], 32), "the four lower legs"),
    ("snowden", "snowden.ply.xz", False, ([-0.075, 2.0, 0.325], [1.575, 1.45, 1.925], [0, 0, 0]), 1, 60,
     ([1.5, 1.0, 13], [0.2, 0.6, -0.4], [0, 1, 0], 36), "the head with ears and glasses"),
    ("scan_trex", "scan_rs1.ply.xz", False, ([-45, 25, -609], [37, 37, 31], [0, 0, 0]), 2, 60,
     ([-23, -4, -200], [-23, -4, -656], [1, 0, 0], 36), "a T-rex's head, teeth and claws in a range scan"),
    ("devil_hair", "devil_hair.ply.xz", False, ([0, 0.5, 7.75], [14.5, 17.5, 12.75], [0, 0, 0]), 2, 90,
     ([50, 60, 20], [0, 0, 5], [0, 0, 1], 36),
     "an open head with separate eyeballs and 12 hair cards (open sheets) down its back"),
    ("man_cape", "man_cape.ply.xz", False, ([0, 0.05, 0.19], [0.2, 0.16, 0.33], [0, 0, 0]), 2, 60,
     ([0.8, 1.1, 0.45], [0, 0.03, 0.15], [0, 0, 1], 28),
     "a figure's upper body and head with a cape (an open, folded sheet) and a collar (a separate shell)"),
]


# Single scenes beyond the four per mesh: name, mesh, box, extra fields, camera, what it shows.
SINGLE = [
    ("man_whole_cut", "man.ply.xz", ([0, 0, 0], [0.22, 0.155, 0.505], [180, 0, 0]),
     {"deformer": {"type": "box_cut", "wedge": {"axis": "z", "from_deg": 0, "angle_deg": 90}},
      "cut_mode": "solid"},
     ([-0.55, -0.45, 0], [-0.1875, 0.0325, -0.0275], [0, 0, 1], 20),
     "a solid cut of the whole figure, seen at one hand (a voxel about a finger thick)"),
    ("card_twist", "card.ply", ([0.5, 11, 0], [2.2, 1, 1], [0, 0, 0]),
     {"deformer": {"type": "twist", "axis": "x", "angle_deg": 180}},
     ([0.5, 14.5, 7], [0.5, 11, 0], [0, 1, 0], 36),
     "a single card (an open sheet, 4 x 1.5 units) twisted half a turn"),
]


def camera(eye, target, up, fov):
    d = math.dist(eye, target)
    return {"projection": "perspective", "eye": eye, "target": target, "up": up, "fov_y_deg": fov,
            "near": round(0.02 * d, 6), "far": round(20 * d, 6)}


def main():
    os.makedirs(out, exist_ok=True)
    for name, mesh, closed, (centre, half, rot), t, angle, cam, what in MESHES:
        b = (t + 1) % 3
        c = (t + 2) % 3
        box = {"centre": centre, "half_extents": half, "rotation_deg": rot}
        cases = {
            "twist": {"deformer": {"type": "twist", "axis": AX[t], "angle_deg": angle}},
            "bend": {"deformer": {"type": "bend", "axis": AX[b], "angle_deg": 60}},
            "cut": {"deformer": {"type": "box_cut", "wedge": {"axis": AX[t], "from_deg": 0, "angle_deg": 90}},
                    "cut_mode": "solid" if closed else "hollow"},
            "incision": {"deformer": {"type": "incision", "axis": AX[b], "from": "+" + AX[t],
                                      "depth": round(1.2 * half[t], 6),
                                      "opening": round(0.3 * min(half[b], half[c]), 6)},
                         "cut_mode": "hollow"},
        }
        for kind, extra in cases.items():
            scene = {"mesh": "../meshes/" + mesh, "boxes": [dict(box, **extra)],
                     "camera": camera(*cam)}
            with open(os.path.join(out, f"{name}_{kind}.json"), "w") as f:
                f.write("// " if False else "")
                json.dump(scene, f, indent=2)
                f.write("\n")
    for name, mesh, (centre, half, rot), extra, cam, _ in SINGLE:
        box = {"centre": centre, "half_extents": half, "rotation_deg": rot}
        scene = {"mesh": "../meshes/" + mesh, "boxes": [dict(box, **extra)], "camera": camera(*cam)}
        with open(os.path.join(out, f"{name}.json"), "w") as f:
            json.dump(scene, f, indent=2)
            f.write("\n")
    with open(os.path.join(out, "README.md"), "w") as f:
        f.write("# Scenes on meshes nobody tuned for\n\n"
                "Written by `scripts/make_zoo.py`: a twist, a bend, a box cut (solid on closed meshes, "
                "hollow on open ones) and a hollow incision on each mesh, at raywarp's default "
                "settings. `tests/zoo_test.cpp` renders each against its exact ground truth; the "
                "figures are in `docs/meshes.md`.\n\n| scenes | mesh | the box holds |\n| --- | --- | --- |\n")
        for name, mesh, closed, _, _, _, _, what in MESHES:
            f.write(f"| `{name}_*.json` | `{mesh}` ({'closed' if closed else 'open'}) | {what} |\n")
        for name, mesh, _, _, _, what in SINGLE:
            f.write(f"| `{name}.json` | `{mesh}` | {what} |\n")


main()
