// raywarp viewer: a static WebGL2 page that renders the entries of a raywarp library
// (../index.json) as raywarp's renderer does (gl/renderer.cpp): pass 1 rasterises the mesh with
// the fragments inside every box discarded, pass 2 ray casts each box's deformed part over its
// region with the box's shader variant (the GLSL ES 3.00 files of the entry), composited by depth.
// Query: ?entry=NAME or ?entry=N (0-based), &width=W&height=H for a fixed canvas size,
// &textures=half to upload half floats only. Keys
// left/right flip through the entries. When a frame is drawn, document.title is
// "raywarp viewer: ready" (or "raywarp viewer: error: ...") and document.body.dataset.status says
// what was drawn, for headless tests.
'use strict';

(function () {
  const LIBRARY = '../';  // the viewer lives in OUT/viewer/, the index in OUT/
  // Texture units of the ray-cast pass (gl/raycast_tables.h, kTextureUnits).
  const UNITS = { u_sdf: 0, u_deformation: 1, u_alpha: 2, u_bricks: 3, u_sdf_bricks: 4, u_depth: 5 };
  const SEAM_VOXELS = 1.0;  // kSeamVoxels (library/textures.h); the sidecar repeats it

  const canvas = document.getElementById('view');
  const panel = document.getElementById('panel');
  const statusLine = document.getElementById('status');
  const query = new URLSearchParams(window.location.search);
  const fixedWidth = parseInt(query.get('width') || '0', 10);
  const fixedHeight = parseInt(query.get('height') || '0', 10);
  const fixedSize = fixedWidth > 0 && fixedHeight > 0;
  // &textures=half: upload half floats even where 32-bit float textures filter (a test of the
  // path for GPUs without OES_texture_float_linear).
  const forceHalf = query.get('textures') === 'half';

  let index = null;
  let current = -1;
  let generation = 0;  // a newer show() makes an older one's results stale
  let gl = null;
  let scene = null;  // the GPU state of the entry shown

  function setStatus(text, error) {
    document.body.dataset.status = text;
    statusLine.textContent = text;
    document.title = error ? 'raywarp viewer: error: ' + text : 'raywarp viewer: ready';
  }
  function setLoading(text) {
    document.title = 'raywarp viewer: loading';
    document.body.dataset.status = 'loading: ' + text;
    statusLine.textContent = 'loading: ' + text;
  }

  // XMLHttpRequest, not fetch: it also reads file:// URLs (chromium --allow-file-access-from-files),
  // where a success has status 0.
  function load(url, type) {
    return new Promise((resolve, reject) => {
      const xhr = new XMLHttpRequest();
      xhr.open('GET', url);
      xhr.responseType = type;
      xhr.onload = () => {
        if ((xhr.status === 200 || xhr.status === 0) && xhr.response !== null) resolve(xhr.response);
        else reject(new Error(url + ': HTTP ' + xhr.status));
      };
      xhr.onerror = () => reject(new Error(url + ': cannot load'));
      xhr.send();
    });
  }
  const loadText = (url) => load(url, 'text');
  const loadJson = (url) => loadText(url).then((t) => {
    try { return JSON.parse(t); } catch (e) { throw new Error(url + ': not JSON: ' + e.message); }
  });
  const loadBytes = (url) => load(url, 'arraybuffer');

  // ---- small linear algebra, in double; matrices are arrays of rows ----
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => Math.sqrt(dot(a, a));
  const normalize = (a) => { const n = norm(a); return [a[0] / n, a[1] / n, a[2] / n]; };
  const mul3 = (a, b) => [a[0] * b[0], a[1] * b[1], a[2] * b[2]];
  const div3 = (a, b) => [a[0] / b[0], a[1] / b[1], a[2] / b[2]];

  function matmul(a, b) {
    const n = a.length, m = b[0].length, k = b.length;
    const out = [];
    for (let i = 0; i < n; ++i) {
      out.push([]);
      for (let j = 0; j < m; ++j) {
        let s = 0;
        for (let l = 0; l < k; ++l) s += a[i][l] * b[l][j];
        out[i].push(s);
      }
    }
    return out;
  }

  // Gauss-Jordan with partial pivoting.
  function inverse(m) {
    const n = m.length;
    const a = m.map((row, i) => row.concat(Array.from({ length: n }, (_, j) => (i === j ? 1 : 0))));
    for (let c = 0; c < n; ++c) {
      let p = c;
      for (let r = c + 1; r < n; ++r) if (Math.abs(a[r][c]) > Math.abs(a[p][c])) p = r;
      [a[c], a[p]] = [a[p], a[c]];
      const d = a[c][c];
      if (d === 0) throw new Error('a singular matrix');
      for (let j = 0; j < 2 * n; ++j) a[c][j] /= d;
      for (let r = 0; r < n; ++r) {
        if (r === c) continue;
        const f = a[r][c];
        if (f !== 0) for (let j = 0; j < 2 * n; ++j) a[r][j] -= f * a[c][j];
      }
    }
    return a.map((row) => row.slice(n));
  }

  function columnMajor(m) {
    const n = m.length, out = new Float32Array(n * n);
    for (let c = 0; c < n; ++c) for (let r = 0; r < n; ++r) out[c * n + r] = m[r][c];
    return out;
  }

  // library/camera.cpp: Camera::view (gluLookAt) and projection_matrix.
  function cameraOf(json) {
    return {
      orthographic: json.projection === 'orthographic',
      eye: json.eye, target: json.target, up: json.up || [0, 1, 0],
      fov: json.fov_y_deg !== undefined ? json.fov_y_deg : 45.0,
      orthoHeight: json.ortho_height !== undefined ? json.ortho_height : 2.0,
      near: json.near !== undefined ? json.near : 0.01,
      far: json.far !== undefined ? json.far : 1000.0,
    };
  }
  function viewMatrix(c) {
    const f = normalize(sub(c.target, c.eye));
    const s = normalize(cross(f, c.up));
    const u = cross(s, f);
    return [[s[0], s[1], s[2], -dot(s, c.eye)], [u[0], u[1], u[2], -dot(u, c.eye)],
            [-f[0], -f[1], -f[2], dot(f, c.eye)], [0, 0, 0, 1]];
  }
  function projectionMatrix(c, aspect) {
    const n = c.near, f = c.far;
    const p = [[0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]];
    if (!c.orthographic) {
      const k = 1.0 / Math.tan(0.5 * c.fov * Math.PI / 180.0);
      p[0][0] = k / aspect; p[1][1] = k;
      p[2][2] = (f + n) / (n - f); p[2][3] = 2.0 * f * n / (n - f); p[3][2] = -1.0;
    } else {
      const t = 0.5 * c.orthoHeight, r = t * aspect;
      p[0][0] = 1.0 / r; p[1][1] = 1.0 / t;
      p[2][2] = -2.0 / (f - n); p[2][3] = -(f + n) / (f - n); p[3][3] = 1.0;
    }
    return p;
  }

  // library/image.cpp srgb_encode.
  function srgbEncode(x) {
    const c = Math.min(Math.max(x, 0.0), 1.0);
    return c < 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1.0 / 2.4) - 0.055;
  }

  // ---- KTX2 (what library/ktx2.cpp writes: one level of a 3D float texture) ----
  const KTX2_ID = [0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];
  const VK_FORMATS = {  // vkFormat -> [channels, half]
    76: [1, true], 83: [2, true], 97: [4, true], 100: [1, false], 103: [2, false], 109: [4, false],
  };
  let halfTable = null;
  function halfToFloat(h) {
    const s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 0x1f, m = h & 0x3ff;
    if (e === 0) return s * m * Math.pow(2, -24);
    if (e === 31) return m ? NaN : s * Infinity;
    return s * (1 + m / 1024) * Math.pow(2, e - 15);
  }
  function readKtx2(buffer, where) {
    const dv = new DataView(buffer);
    if (buffer.byteLength < 104) throw new Error(where + ': too short for KTX2');
    for (let i = 0; i < 12; ++i)
      if (dv.getUint8(i) !== KTX2_ID[i]) throw new Error(where + ': not a KTX2 file');
    const u32 = (o) => dv.getUint32(o, true);
    const u64 = (o) => u32(o) + u32(o + 4) * 4294967296;
    const vkFormat = u32(12);
    const dims = [u32(20), Math.max(u32(24), 1), Math.max(u32(28), 1)];
    const layers = u32(32), faces = u32(36), levels = u32(40), scheme = u32(44);
    const format = VK_FORMATS[vkFormat];
    if (!format) throw new Error(where + ': vkFormat ' + vkFormat + ' is not one raywarp writes');
    if (layers > 1 || faces !== 1 || levels > 1 || scheme !== 0)
      throw new Error(where + ': layers, faces, levels or supercompression raywarp does not write');
    const offset = u64(80), length = u64(88);
    const [channels, half] = format;
    const count = dims[0] * dims[1] * dims[2] * channels;
    if (length !== count * (half ? 2 : 4) || offset + length > buffer.byteLength)
      throw new Error(where + ': level 0 holds ' + length + ' bytes, expected ' + count * (half ? 2 : 4));
    const bytes = buffer.slice(offset, offset + length);  // aligned copy
    let values;
    if (half) {
      if (!halfTable) {
        halfTable = new Float32Array(65536);
        for (let i = 0; i < 65536; ++i) halfTable[i] = halfToFloat(i);
      }
      const raw = new Uint16Array(bytes);
      values = new Float32Array(count);
      for (let i = 0; i < count; ++i) values[i] = halfTable[raw[i]];
    } else {
      values = new Float32Array(bytes);
    }
    return { dims, channels, half, values };
  }

  // Float to half bits, round to nearest even (for GPUs without linear filtering of floats).
  const f32 = new Float32Array(1), u32v = new Uint32Array(f32.buffer);
  function floatToHalf(x) {
    f32[0] = x;
    const b = u32v[0], sign = (b >>> 16) & 0x8000, e = (b >>> 23) & 0xff;
    let m = b & 0x7fffff;
    if (e === 0xff) return sign | 0x7c00 | (m ? 0x200 : 0);
    let he = e - 127 + 15;
    if (he >= 31) return sign | 0x7bff;  // clamp to the largest half, as round_to_half does
    if (he <= 0) {
      if (he < -10) return sign;
      m |= 0x800000;
      const shift = 14 - he;
      let hm = m >>> shift;
      const rest = m & ((1 << shift) - 1), halfway = 1 << (shift - 1);
      if (rest > halfway || (rest === halfway && (hm & 1))) hm += 1;
      return sign | hm;
    }
    let hm = m >>> 13;
    const rest = m & 0x1fff;
    if (rest > 0x1000 || (rest === 0x1000 && (hm & 1))) {
      hm += 1;
      if (hm === 0x400) { hm = 0; he += 1; if (he >= 31) return sign | 0x7bff; }
    }
    return sign | (he << 10) | hm;
  }

  // ---- GL helpers ----
  function compile(kind, source, name) {
    const s = gl.createShader(kind);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS))
      throw new Error(name + ' does not compile: ' + gl.getShaderInfoLog(s));
    return s;
  }
  function program(vertexSource, fragmentSource, names) {
    const p = gl.createProgram();
    gl.attachShader(p, compile(gl.VERTEX_SHADER, vertexSource, names[0]));
    gl.attachShader(p, compile(gl.FRAGMENT_SHADER, fragmentSource, names[1]));
    gl.bindAttribLocation(p, 0, 'a_position');
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS))
      throw new Error(names.join(' + ') + ' do not link: ' + gl.getProgramInfoLog(p));
    return p;
  }
  // The renderer's Uniforms: a name the program does not use is ignored (location null).
  function uniforms(p) {
    const loc = (n) => gl.getUniformLocation(p, n);
    return {
      mat4: (n, m) => gl.uniformMatrix4fv(loc(n), false, columnMajor(m)),
      mat3: (n, m) => gl.uniformMatrix3fv(loc(n), false, columnMajor(m)),
      vec3: (n, v) => gl.uniform3f(loc(n), v[0], v[1], v[2]),
      vec4: (n, v) => gl.uniform4f(loc(n), v[0], v[1], v[2], v[3]),
      vec2: (n, x, y) => gl.uniform2f(loc(n), x, y),
      f1: (n, x) => gl.uniform1f(loc(n), x),
      i1: (n, x) => gl.uniform1i(loc(n), x),
    };
  }

  function upload3d(tex, object, floatLinear, nearest, repeat) {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_3D, t);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    const one = tex.channels === 1;
    if (tex.channels !== 1 && tex.channels !== 4)
      throw new Error('a texture of ' + tex.channels + ' channels');
    const [w, h, d] = tex.dims;
    if (floatLinear || nearest) {
      gl.texImage3D(gl.TEXTURE_3D, 0, one ? gl.R32F : gl.RGBA32F, w, h, d, 0, one ? gl.RED : gl.RGBA,
                    gl.FLOAT, object);
    } else {
      const halves = new Uint16Array(object.length);
      for (let i = 0; i < object.length; ++i) halves[i] = floatToHalf(object[i]);
      gl.texImage3D(gl.TEXTURE_3D, 0, one ? gl.R16F : gl.RGBA16F, w, h, d, 0, one ? gl.RED : gl.RGBA,
                    gl.HALF_FLOAT, halves);
    }
    const filter = nearest ? gl.NEAREST : gl.LINEAR;
    gl.texParameteri(gl.TEXTURE_3D, gl.TEXTURE_MIN_FILTER, filter);
    gl.texParameteri(gl.TEXTURE_3D, gl.TEXTURE_MAG_FILTER, filter);
    // A cylindrical texture repeats (its angle is periodic; the shader clamps r and h itself).
    for (const wrap of [gl.TEXTURE_WRAP_S, gl.TEXTURE_WRAP_T, gl.TEXTURE_WRAP_R])
      gl.texParameteri(gl.TEXTURE_3D, wrap, repeat ? gl.REPEAT : gl.CLAMP_TO_EDGE);
    const err = gl.getError();
    if (err !== gl.NO_ERROR) throw new Error('cannot create a ' + w + 'x' + h + 'x' + d + ' 3D texture (GL error ' + err + ')');
    return t;
  }

  // ---- an entry ----
  function entryFile(entry, name) { return LIBRARY + entry.folder + '/' + name; }

  // One box's textures and the uniforms gl/renderer.cpp derives from BoxTextures, computed from the
  // sidecar as import_box (library/export.cpp) reads it.
  async function loadBox(sidecarPath, shaders, floatLinear) {
    const side = await loadJson(LIBRARY + sidecarPath);
    if (side.schema !== 'raywarp.export') throw new Error(sidecarPath + ': not a raywarp export sidecar');
    if (side.version > 1) throw new Error(sidecarPath + ': version ' + side.version + ', this viewer reads 1');
    const folder = sidecarPath.replace(/[^/]*$/, '');
    const h = side.box.half_extents, R = side.box.rotation, c = side.box.centre;
    const render = side.render;
    const b = { side, h };
    b.boxToObject = [[R[0][0], R[0][1], R[0][2], c[0]], [R[1][0], R[1][1], R[1][2], c[1]],
                     [R[2][0], R[2][1], R[2][2], c[2]], [0, 0, 0, 1]];
    b.objectToBox = inverse(b.boxToObject);
    b.rotation = R;
    b.movesNothing = render.moves_nothing;
    b.hasCut = render.has_cut;
    const voxelSide = render.voxel_box_units * Math.max(h[0], h[1], h[2]);
    b.background = Math.fround(render.distance_background_voxels * voxelSide);
    b.thickness = b.hasCut ? render.shell_thickness_voxels * voxelSide : 0.0;
    b.lipschitz = render.lipschitz < 0 ? Infinity : render.lipschitz;
    b.seamVoxels = render.seam_voxels !== undefined ? render.seam_voxels : SEAM_VOXELS;
    b.regionLower = mul3(render.ray_cast_region.min, h);
    b.regionUpper = mul3(render.ray_cast_region.max, h);
    const H = [[h[0], 0, 0, 0], [0, h[1], 0, 0], [0, 0, h[2], 0], [0, 0, 0, 1]];
    b.textureMap = matmul(matmul(H, side.texture_map), inverse(H));
    if (render.step_bounds) {
      const vl = render.step_bounds.validity_lipschitz_box_units / Math.max(h[0], h[1], h[2]);
      b.invLipschitzW = vl > 0 ? 1.0 / vl : 0.0;
    }
    // A cylindrical box's D (unless it moves nothing) and A are over (theta, r, h) in the units of
    // the sidecar's mapping; their differences step by their smallest of r's and h's spacings.
    const cylindrical = side.mapping && side.mapping.type === 'cylindrical';
    const overCylinder = (name) => cylindrical && (name === 'alpha' || (name === 'deformation' && !b.movesNothing));
    if (cylindrical) {
      const a = 'xyz'.indexOf(side.mapping.axis);
      const unit = (k) => [0, 1, 2].map((i) => (i === k ? 1 : 0));
      b.cylinder = { u: unit((a + 1) % 3), v: unit((a + 2) % 3), a: unit(a) };
    }
    // Each texture's grid in the box frame, and its texels in object units.
    b.grids = {};
    b.textures = {};
    const wanted = { distance: 'u_sdf', deformation: 'u_deformation', alpha: 'u_alpha',
                     step_bounds_d: 'u_bricks', step_bounds_sdf: 'u_sdf_bricks' };
    const loads = [];
    for (const name of Object.keys(wanted)) {
      const t = side.textures[name];
      if (!t) continue;
      const units = overCylinder(name) ? side.mapping.units : h;
      const origin = mul3(t.region.min, units), upper = mul3(t.region.max, units);
      const size = sub(upper, origin);
      let spacing = div3(size, t.dims);
      if (overCylinder(name)) spacing = [0, 0, 0].fill(Math.min(spacing[1], spacing[2]));
      b.grids[name] = { origin, size, spacing, dims: t.dims };
      if (name === 'deformation' && b.movesNothing) continue;  // the renderer uploads none
      if (name === 'alpha' && !b.hasCut) continue;
      if (name.startsWith('step_bounds') && !shaders.defines.includes('RAYWARP_SAMPLING_BOUNDED')) continue;
      const file = side.files.find((f) => f.texture === name && f.format === 'ktx2');
      if (!file) throw new Error(sidecarPath + ': no ktx2 file of ' + name);
      const path = LIBRARY + folder + file.file;
      loads.push(loadBytes(path).then((bytes) => {
        const k = readKtx2(bytes, path);
        if (k.dims.join() !== t.dims.join() || k.channels !== t.scale.length)
          throw new Error(path + ': holds ' + k.dims.join('x') + 'x' + k.channels + ' texels, the sidecar says ' +
                          t.dims.join('x') + 'x' + t.scale.length);
        const object = new Float32Array(k.values.length);
        for (let i = 0; i < object.length; ++i) object[i] = k.values[i] * t.scale[i % k.channels];
        b.textures[wanted[name]] = upload3d(k, object, floatLinear, name.startsWith('step_bounds'),
                                            overCylinder(name));
        b.half = b.half || k.half;
      }));
    }
    await Promise.all(loads);
    if (!b.grids.distance) throw new Error(sidecarPath + ': no distance grid');
    const sp = b.grids.distance.spacing;
    b.voxel = Math.min(sp[0], sp[1], sp[2]);  // implicit_spacing: the grid's voxel()
    const def = b.grids.deformation, alpha = b.grids.alpha;
    b.cutMargin = b.hasCut && alpha ? norm(alpha.spacing) + 0.5 * (def ? norm(def.spacing) : 0) : 0.0;
    return b;
  }

  function parseMesh(buffer, where) {
    const dv = new DataView(buffer);
    const magic = String.fromCharCode(dv.getUint8(0), dv.getUint8(1), dv.getUint8(2), dv.getUint8(3));
    if (magic !== 'RWM1') throw new Error(where + ': not a raywarp mesh (RWM1)');
    const nv = dv.getUint32(4, true), nt = dv.getUint32(8, true);
    if (buffer.byteLength !== 12 + nv * 24 + nt * 12) throw new Error(where + ': wrong length');
    return {
      positions: new Float32Array(buffer, 12, nv * 3),
      normals: new Float32Array(buffer, 12 + nv * 12, nv * 3),
      indices: new Uint32Array(buffer, 12 + nv * 24, nt * 3),
      vertices: nv, triangles: nt,
    };
  }

  function releaseScene() {
    if (!scene) return;
    for (const b of scene.boxes) for (const t of Object.values(b.textures)) gl.deleteTexture(t);
    for (const p of scene.programs) gl.deleteProgram(p);
    for (const x of scene.buffers) gl.deleteBuffer(x);
    for (const v of scene.vaos) gl.deleteVertexArray(v);
    scene = null;
  }

  function ensureContext() {
    if (gl) return;
    gl = canvas.getContext('webgl2', { antialias: false, depth: true, alpha: false,
                                       preserveDrawingBuffer: true, premultipliedAlpha: false });
    if (!gl) throw new Error('no WebGL2');
  }

  async function build(entry, myGeneration) {
    ensureContext();
    const floatLinear = !forceHalf && !!gl.getExtension('OES_texture_float_linear');
    const shaders = entry.shaders;
    const src = (name) => loadText(entryFile(entry, name));
    const [meshBytes, rasterVert, rasterFrag] = await Promise.all([
      loadBytes(LIBRARY + entry.mesh), src(shaders.raster.glsl_es300.vertex),
      src(shaders.raster.glsl_es300.fragment)]);
    const boxShaders = await Promise.all(shaders.boxes.map((s) => Promise.all(
      [src(s.glsl_es300.vertex), src(s.glsl_es300.fragment)])));
    if (myGeneration !== generation) return null;
    const boxes = [];
    for (let i = 0; i < entry.boxes.length; ++i)
      boxes.push(await loadBox(entry.boxes[i], shaders.boxes[i], floatLinear));
    if (myGeneration !== generation) {
      for (const b of boxes) for (const t of Object.values(b.textures)) gl.deleteTexture(t);
      return null;
    }
    releaseScene();
    const s = { boxes, programs: [], buffers: [], vaos: [], floatLinear };
    s.raster = program(rasterVert, rasterFrag, [shaders.raster.glsl_es300.vertex, shaders.raster.glsl_es300.fragment]);
    s.programs.push(s.raster);
    boxes.forEach((b, i) => {
      b.program = program(boxShaders[i][0], boxShaders[i][1],
                          [shaders.boxes[i].glsl_es300.vertex, shaders.boxes[i].glsl_es300.fragment]);
      b.defines = shaders.boxes[i].defines;
      s.programs.push(b.program);
      gl.useProgram(b.program);
      for (const [sampler, unit] of Object.entries(UNITS)) {
        const loc = gl.getUniformLocation(b.program, sampler);
        if (loc) gl.uniform1i(loc, unit);
      }
    });
    // The mesh: positions at location 0, vertex normals at 1 (Renderer::set_mesh).
    const mesh = parseMesh(meshBytes, entry.mesh);
    s.mesh = mesh;
    s.meshVao = gl.createVertexArray();
    gl.bindVertexArray(s.meshVao);
    const attribute = (loc, data) => {
      const buf = gl.createBuffer();
      gl.bindBuffer(gl.ARRAY_BUFFER, buf);
      gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
      gl.vertexAttribPointer(loc, 3, gl.FLOAT, false, 0, 0);
      gl.enableVertexAttribArray(loc);
      s.buffers.push(buf);
    };
    attribute(0, mesh.positions);
    attribute(1, mesh.normals);
    const ebo = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, ebo);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, mesh.indices, gl.STATIC_DRAW);
    s.buffers.push(ebo);
    // The unit cube, scaled onto each box's region by the vertex shader (Renderer::Renderer).
    const corners = new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 1]);
    const faces = new Uint32Array([0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                   2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5]);
    s.cubeVao = gl.createVertexArray();
    gl.bindVertexArray(s.cubeVao);
    attribute(0, corners);
    gl.disableVertexAttribArray(1);
    const cebo = gl.createBuffer();
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, cebo);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, faces, gl.STATIC_DRAW);
    s.buffers.push(cebo);
    gl.bindVertexArray(null);
    s.vaos.push(s.meshVao, s.cubeVao);
    scene = s;
    return s;
  }

  // An offscreen target like the renderer's (RGBA8 colour, 32-bit float depth), blitted to the canvas.
  let fbo = null, fboColour = null, fboDepth = null, fboW = 0, fboH = 0;
  function ensureFramebuffer(w, h) {
    if (fbo && w === fboW && h === fboH) return;
    if (fbo) { gl.deleteFramebuffer(fbo); gl.deleteRenderbuffer(fboColour); gl.deleteRenderbuffer(fboDepth); }
    fboColour = gl.createRenderbuffer();
    gl.bindRenderbuffer(gl.RENDERBUFFER, fboColour);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.RGBA8, w, h);
    fboDepth = gl.createRenderbuffer();
    gl.bindRenderbuffer(gl.RENDERBUFFER, fboDepth);
    gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT32F, w, h);
    fbo = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.RENDERBUFFER, fboColour);
    gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, fboDepth);
    gl.drawBuffers([gl.COLOR_ATTACHMENT0, gl.NONE]);  // output 1 (linear depth) is not kept
    if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE)
      throw new Error('cannot make a ' + w + 'x' + h + ' framebuffer');
    fboW = w; fboH = h;
  }

  // Renderer::render, pass for pass.
  function draw(entry, w, h) {
    const s = scene;
    const settings = entry.render;
    const camera = cameraOf(entry.camera);
    ensureFramebuffer(w, h);
    gl.bindFramebuffer(gl.FRAMEBUFFER, fbo);
    gl.viewport(0, 0, w, h);
    const bg = settings.background;
    gl.clearBufferfv(gl.COLOR, 0, [srgbEncode(bg[0]), srgbEncode(bg[1]), srgbEncode(bg[2]), 1.0]);
    gl.clearBufferfv(gl.DEPTH, 0, [1.0]);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS);
    gl.disable(gl.CULL_FACE);

    const viewProj = matmul(projectionMatrix(camera, w / h), viewMatrix(camera));
    const invViewProj = inverse(viewProj);
    const setCamera = (u) => {
      u.mat4('u_view_proj', viewProj);
      u.mat4('u_inv_view_proj', invViewProj);
      u.vec3('u_eye', camera.eye);
      u.vec3('u_view_dir', normalize(sub(camera.target, camera.eye)));
      u.vec2('u_viewport', w, h);
      u.i1('u_orthographic', camera.orthographic ? 1 : 0);
      u.vec3('u_albedo', [0, 0, 0]);
    };
    const anyCut = s.boxes.some((b) => b.hasCut);

    // Pass 1: the mesh outside the boxes.
    gl.useProgram(s.raster);
    const r = uniforms(s.raster);
    setCamera(r);
    r.vec3('u_albedo', settings.colour);
    r.vec3('u_inside_colour', settings.inside_colour);
    r.i1('u_two_sided', anyCut ? 1 : 0);
    r.i1('u_box_count', s.boxes.length);
    s.boxes.forEach((b, i) => {
      r.mat4('u_object_to_box[' + i + ']', b.objectToBox);
      r.vec3('u_half_extents[' + i + ']', b.h);
    });
    gl.bindVertexArray(s.meshVao);
    gl.drawElements(gl.TRIANGLES, s.mesh.indices.length, gl.UNSIGNED_INT, 0);

    // Pass 2: per box, ray cast over its region; back faces only.
    gl.enable(gl.CULL_FACE);
    gl.cullFace(gl.FRONT);
    gl.bindVertexArray(s.cubeVao);
    for (const b of s.boxes) {
      gl.useProgram(b.program);
      const u = uniforms(b.program);
      setCamera(u);
      u.vec3('u_albedo', settings.colour);
      u.vec3('u_inside_colour', settings.inside_colour);
      u.vec3('u_cut_colour', settings.cut_colour);
      u.i1('u_max_steps', settings.max_steps);
      u.i1('u_refine_steps', settings.refine_steps);
      const voxel = b.voxel;
      const sdf = b.grids.distance, def = b.grids.deformation, alpha = b.grids.alpha;
      u.mat4('u_box_to_object', b.boxToObject);
      u.mat4('u_object_to_box', b.objectToBox);
      u.mat3('u_box_to_object_dir', b.rotation);
      u.vec3('u_half_extents', b.h);
      u.vec3('u_region_lower', b.regionLower);
      u.vec3('u_region_upper', b.regionUpper);
      u.vec3('u_sdf_origin', sdf.origin);
      u.vec3('u_sdf_size', sdf.size);
      u.f1('u_sdf_spacing', voxel);
      // Uploaded in object units (decoded at load): no decode in the shader.
      u.vec4('u_def_decode', [1, 1, 1, 1]);
      u.f1('u_sdf_decode', 1);
      u.f1('u_alpha_decode', 1);
      u.f1('u_background', b.background);
      if (def) {
        u.vec3('u_def_origin', def.origin);
        u.vec3('u_def_size', def.size);
        u.vec3('u_def_spacing', def.spacing);
      }
      if (b.cylinder) {
        u.vec3('u_cyl_e_u', b.cylinder.u);
        u.vec3('u_cyl_e_v', b.cylinder.v);
        u.vec3('u_cyl_e_a', b.cylinder.a);
      }
      // M by its rows (march.glsl's convention for matrices an engine fills).
      u.vec4('u_texture_map_x', b.textureMap[0]);
      u.vec4('u_texture_map_y', b.textureMap[1]);
      u.vec4('u_texture_map_z', b.textureMap[2]);
      if (alpha) {
        u.vec3('u_alpha_origin', alpha.origin);
        u.vec3('u_alpha_size', alpha.size);
        u.vec3('u_alpha_spacing', alpha.spacing);
      }
      u.f1('u_thickness', b.thickness);
      u.f1('u_lipschitz', b.lipschitz);
      u.f1('u_cut_margin', b.cutMargin);
      u.f1('u_step', settings.step_voxels * voxel);
      u.f1('u_threshold', settings.threshold_voxels * voxel);
      u.f1('u_fine_factor', settings.fine_factor);
      u.f1('u_seam', b.seamVoxels * voxel);
      if (b.defines.includes('RAYWARP_SAMPLING_BOUNDED')) {
        const bricks = b.grids.step_bounds_d, sdfBricks = b.grids.step_bounds_sdf;
        u.vec3('u_brick_origin', bricks.origin);
        u.vec3('u_brick_spacing', bricks.spacing);
        u.vec3('u_sdf_brick_origin', sdfBricks.origin);
        u.f1('u_sdf_brick_spacing', Math.min(...sdfBricks.spacing));
        u.f1('u_inv_lipschitz_w', b.invLipschitzW || 0.0);
        u.f1('u_epsilon', settings.hit_epsilon_voxels * voxel);
      }
      for (const [sampler, unit] of Object.entries(UNITS)) {
        gl.activeTexture(gl.TEXTURE0 + unit);
        const target = sampler === 'u_depth' ? gl.TEXTURE_2D_ARRAY : gl.TEXTURE_3D;
        gl.bindTexture(target, b.textures[sampler] || null);
      }
      gl.activeTexture(gl.TEXTURE0);
      gl.drawElements(gl.TRIANGLES, 36, gl.UNSIGNED_INT, 0);
    }
    gl.disable(gl.CULL_FACE);
    gl.bindVertexArray(null);

    // To the canvas.
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, fbo);
    gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, null);
    gl.blitFramebuffer(0, 0, w, h, 0, 0, w, h, gl.COLOR_BUFFER_BIT, gl.NEAREST);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.finish();
    const err = gl.getError();
    if (err !== gl.NO_ERROR) throw new Error('GL error ' + err + ' while drawing');
  }

  function canvasSize(entry) {
    if (fixedSize) return [fixedWidth, fixedHeight];
    const ratio = window.devicePixelRatio || 1;
    return [Math.max(1, Math.round(window.innerWidth * ratio)), Math.max(1, Math.round(window.innerHeight * ratio))];
  }

  function layout(w, h) {
    canvas.width = w;
    canvas.height = h;
    if (fixedSize) {
      canvas.style.width = w + 'px';
      canvas.style.height = h + 'px';
      panel.style.left = w + 'px';  // beside the canvas, so a screenshot of W x H shows the frame alone
    } else {
      canvas.style.width = '100vw';
      canvas.style.height = '100vh';
    }
  }

  function describe(entry, s, w, h, ms) {
    const boxes = s.boxes.map((b, i) => 'box ' + i + ': ' +
      b.defines.map((d) => d.replace('RAYWARP_', '').toLowerCase()).join(' ')).join('; ');
    return 'ready: entry ' + entry.name + ' (' + (current + 1) + ' of ' + index.entries.length + '), ' +
      w + 'x' + h + ', ' + s.mesh.triangles + ' triangles, ' + s.boxes.length + ' box' +
      (s.boxes.length === 1 ? '' : 'es') + ' (' + boxes + '), textures ' +
      (s.floatLinear ? 'float32' : 'half') + ', ' + Math.round(ms) + ' ms';
  }

  async function show(i) {
    const n = index.entries.length;
    current = ((i % n) + n) % n;
    const myGeneration = ++generation;
    const entry = index.entries[current];
    document.getElementById('entry-name').textContent = entry.name;
    for (const [k, li] of Array.from(document.querySelectorAll('#entries li')).entries())
      li.className = k === current ? 'current' : '';
    const url = new URL(window.location.href);
    url.searchParams.set('entry', entry.name);
    try { window.history.replaceState(null, '', url.toString()); } catch (e) { /* file:// may refuse */ }
    setLoading(entry.name);
    const start = performance.now();
    try {
      const s = await build(entry, myGeneration);
      if (!s) return;
      const [w, h] = canvasSize(entry);
      layout(w, h);
      draw(entry, w, h);
      const ms = performance.now() - start;
      // Let the frame reach the page before saying so.
      requestAnimationFrame(() => {
        if (myGeneration === generation) setStatus(describe(entry, s, w, h, ms), false);
      });
    } catch (e) {
      if (myGeneration === generation) setStatus(entry.name + ': ' + (e && e.message ? e.message : e), true);
    }
  }

  function redraw() {
    if (!scene || current < 0) return;
    const entry = index.entries[current];
    const [w, h] = canvasSize(entry);
    try { layout(w, h); draw(entry, w, h); } catch (e) { setStatus(entry.name + ': ' + e.message, true); }
  }

  async function main() {
    try {
      index = await loadJson(LIBRARY + 'index.json');
      if (index.schema !== 'raywarp.library') throw new Error('index.json: not a raywarp library');
      if (!index.entries || index.entries.length === 0) throw new Error('index.json: no entries');
    } catch (e) {
      setStatus(e.message, true);
      return;
    }
    const list = document.getElementById('entries');
    index.entries.forEach((entry, k) => {
      const li = document.createElement('li');
      li.textContent = entry.name;
      if (entry.thumbnail) {
        const img = document.createElement('img');
        img.src = LIBRARY + entry.thumbnail;
        img.alt = '';
        img.onerror = () => img.remove();
        li.appendChild(img);
      }
      li.addEventListener('click', () => show(k));
      list.appendChild(li);
    });
    let first = 0;
    const wanted = query.get('entry');
    if (wanted !== null) {
      const byName = index.entries.findIndex((e) => e.name === wanted);
      if (byName >= 0) first = byName;
      else if (/^\d+$/.test(wanted) && parseInt(wanted, 10) < index.entries.length) first = parseInt(wanted, 10);
      else { setStatus('no entry "' + wanted + '" in index.json', true); return; }
    }
    window.addEventListener('keydown', (ev) => {
      if (ev.key === 'ArrowRight') show(current + 1);
      else if (ev.key === 'ArrowLeft') show(current - 1);
    });
    if (!fixedSize) window.addEventListener('resize', redraw);
    await show(first);
  }

  main();
})();
