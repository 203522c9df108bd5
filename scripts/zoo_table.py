#!/usr/bin/env python3
"""Prints the table of docs/meshes.md: every scene of examples/zoo/ at raywarp's defaults, with
its figures against the exact ground truth at 512x512 (IoU, share of pixels over 1 % of the
diagonal, outline bias, texture memory: tests/zoo_test.cpp) and its cost (distance grid chosen, bake time with no cache,
median frame time of 5 frames at 512x512: `raywarp render --time 5 --no-cache`).
Usage: python3 scripts/zoo_table.py [BUILD_DIR]   (after building; takes a few minutes)"""
import json, os, re, subprocess, sys, tempfile

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.normpath(os.path.join(here, ".."))
build = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build"))
raywarp = os.path.join(build, "raywarp")
zoo = os.path.join(root, "examples", "zoo")
DEFORMER = {"box_cut": "cut"}


def run(cmd, cwd):
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    return r.stdout + r.stderr


with tempfile.TemporaryDirectory() as tmp:
    figures, notes = {}, {}
    for line in run([os.path.join(build, "zoo_test"), "--gtest_filter=Zoo/*"], tmp).splitlines():
        m = re.match(r"\[figures\] zoo (\S+) at 512 x 512: IoU ([\d.]+), over 1% of diag ([\d.]+)%, "
                     r"outline bias ([\d.]+) pixel, ([\d.]+) MiB", line)
        if m:
            figures[m.group(1)] = m.groups()[1:]
        m = re.match(r"\[figures\] zoo (\S+) is below the marks at defaults: (.*)", line)
        if m:
            notes[m.group(1)] = m.group(2)
    meshes = {}
    print("| scene | mesh (triangles) | deformer | IoU | % over 1 % diag | outline bias px | textures MiB "
          "| distance grid | bake s | frame ms (512², llvmpipe) | note |")
    print("| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
    for name in sorted(f[:-5] for f in os.listdir(zoo) if f.endswith(".json")):
        scene_file = os.path.join(zoo, name + ".json")
        scene = json.load(open(scene_file))
        mesh = scene["mesh"]
        if mesh not in meshes:
            info = run([raywarp, "info", os.path.join(zoo, mesh)], tmp)
            m = re.search(r"(\d+) triangles.*?(closed|open)", info)
            meshes[mesh] = f"{int(m.group(1)):,}, {m.group(2)}" if m else "?"
        log = run([raywarp, "render", scene_file, "-o", os.path.join(tmp, "x.png"), "--width", "512",
                   "--height", "512", "--time", "5", "--no-cache"], tmp)
        bake = re.search(r"textures: \d+ baked in ([\d.]+) s", log)
        frame = re.search(r"frames: median ([\d.]+) ms", log)
        grid = re.search(r"implicit resolution auto: .*?: (\d+)(?: within|, held)", log)
        deformer = scene["boxes"][0]["deformer"]["type"]
        iou, over, bias, mib = figures.get(name, ("?", "?", "?", "?"))
        note = notes.get(name, "meets both marks")
        print(f"| `{name}` | `{os.path.basename(mesh)}` ({meshes[mesh]}) | {DEFORMER.get(deformer, deformer)} "
              f"| {iou} | {over} | {bias} | {mib} | {grid.group(1) if grid else '?'} "
              f"| {float(bake.group(1)):.2f} | {float(frame.group(1)):.1f} | {note} |"
              if bake and frame else f"| `{name}` | render failed |")
        sys.stdout.flush()
