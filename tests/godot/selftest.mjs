#!/usr/bin/env node
// Self-test of compile_gdshader.mjs: compiles the fixtures in one run, good and
// broken files interleaved, and checks that every good file passes and every
// broken file fails with the error named on its "// expect-error: ..." line,
// attributed to that file and no other.
//
//   node selftest.mjs            (or: npm test)

import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const list = (dir) => fs.readdirSync(path.join(here, 'fixtures', dir))
  .filter((f) => f.endsWith('.gdshader')).sort().map((f) => path.join('fixtures', dir, f));
const good = list('good');
const bad = list('bad');
const expected = new Map(bad.map((f) => {
  const m = /^\/\/ expect-error: (.+)$/m.exec(fs.readFileSync(path.join(here, f), 'utf8'));
  if (!m) throw new Error(`${f} has no "// expect-error: ..." line`);
  return [f, m[1].trim()];
}));

// good, bad, bad, good, bad, bad, ... so that each broken file sits between others.
const order = [];
for (let i = 0, g = 0; i < bad.length; i++) {
  if (i % 2 === 0) order.push(good[g++ % good.length]);
  order.push(bad[i]);
}
order.push(...good);

const run = spawnSync(process.execPath, [path.join(here, 'compile_gdshader.mjs'), ...order], {
  cwd: here, encoding: 'utf8', timeout: 600000,
});
if (run.status !== 1) {
  process.stderr.write(run.stderr || '');
  console.log(`compile_gdshader.mjs exited with ${run.status ?? run.signal}, expected 1`);
  console.log('0 passed, 1 failed');
  process.exit(1);
}
const report = JSON.parse(run.stdout);
console.log(`Godot ${report.godot}, boot ${report.boot_ms} ms`);

let passed = 0;
let failed = 0;
report.results.forEach((r) => {
  const text = r.errors.join('\n');
  let problem = null;
  if (good.includes(r.file)) {
    if (!r.ok) problem = `should compile but failed:\n    ${r.errors.join('\n    ')}`;
  } else if (r.ok) {
    problem = 'should fail but compiled';
  } else if (!text.includes(expected.get(r.file))) {
    problem = `error does not mention "${expected.get(r.file)}":\n    ${r.errors.join('\n    ')}`;
  } else {
    for (const [other, want] of expected) {
      if (other !== r.file && want !== expected.get(r.file) && text.includes(want)) {
        problem = `also shows the error of ${other} ("${want}")`;
      }
    }
  }
  if (problem) failed++; else passed++;
  console.log(`${problem ? 'FAIL' : 'ok  '} ${String(r.ms).padStart(5)} ms  ${r.file}${problem ? `: ${problem}` : ''}`);
});
if (report.results.length !== order.length) {
  failed++;
  console.log(`expected ${order.length} results, got ${report.results.length}`);
}
console.log(`${passed} passed, ${failed} failed`);
process.exit(failed ? 1 : 0);
