// The npm package as a new user gets it: `npm pack` (prepack builds dist-lib/ with scripts/build/build-lib.mjs),
// the tarball unpacked as node_modules/emdm-web of a scratch folder outside the checkout (its dependencies and the
// three peer linked from this checkout's node_modules: no registry needed), then
// - plain Node imports 'emdm-web' and 'emdm-web/three' by name and generates a BVH from the shipped models;
// - a consumer's strict tsc (erasableSyntaxOnly, no unused locals/parameters, skipLibCheck off) accepts its types;
// - the tarball holds the built library, not models, tests, sources or the Python pipeline, and is under 5 MB;
// - `emdm-web models|ort` copies a verified models folder / ORT's browser runtimes into an app's static folder;
// - a Vite app whose only wiring is `emdm({ models })` from 'emdm-web/vite' generates a motion in Chromium, from
//   its production build (vite build + vite preview) and its dev server, cross-origin isolated, fetching nothing
//   from another host, its dist/ without ORT .wasm under assets/.
import { type ChildProcess, execFileSync, spawn } from 'node:child_process';
import { createHash } from 'node:crypto';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { chromium } from 'playwright-core';
import { afterAll, beforeAll, describe, expect, it } from 'vitest';

const ROOT = path.resolve(__dirname, '../..');
const MODELS = path.join(ROOT, 'public', 'models');
const pkg = JSON.parse(fs.readFileSync(path.join(ROOT, 'package.json'), 'utf8'));
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-pack-'));
const app = path.join(tmp, 'app');
let packed: { size: number; files: { path: string }[]; filename: string };

function link(name: string): void {
  const to = path.join(app, 'node_modules', name);
  fs.mkdirSync(path.dirname(to), { recursive: true });
  fs.symlinkSync(fs.realpathSync(path.join(ROOT, 'node_modules', name)), to);
}

beforeAll(() => {
  const out = execFileSync('npm', ['pack', '--json', '--pack-destination', tmp], { cwd: ROOT, encoding: 'utf8' });
  packed = JSON.parse(out.slice(out.indexOf('[')))[0];
  const target = path.join(app, 'node_modules', 'emdm-web');
  fs.mkdirSync(target, { recursive: true });
  execFileSync('tar', ['-xzf', path.join(tmp, packed.filename), '-C', target, '--strip-components=1']);
  for (const name of [...Object.keys(pkg.dependencies), ...Object.keys(pkg.peerDependencies), '@types/node', 'vite']) link(name);
  fs.writeFileSync(path.join(app, 'package.json'), JSON.stringify({ name: 'app', type: 'module', private: true }));
}, 180_000);
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));

describe('npm package', () => {
  it('holds the built library only, under 5 MB', () => {
    const files = packed.files.map((f) => f.path);
    expect(packed.size).toBeLessThan(5_000_000);
    expect(files).toEqual(expect.arrayContaining(['package.json', 'LICENSE', 'README.md', 'dist-lib/index.js', 'dist-lib/index.d.ts',
      'dist-lib/three.js', 'dist-lib/three.d.ts', 'dist-lib/vite.js', 'dist-lib/cli.js', 'dist-lib/worker/generation.worker.js']));
    expect(files.filter((f) => !f.startsWith('dist-lib/') && !['package.json', 'LICENSE', 'README.md', 'CHANGELOG.md'].includes(f))).toEqual([]);
    expect(files.filter((f) => /\.(onnx|pt|f32|py)$/.test(f) || (f.endsWith('.ts') && !f.endsWith('.d.ts')))).toEqual([]);
    expect(pkg.private).toBeUndefined();
    expect(pkg.dependencies.three).toBeUndefined();
    expect(pkg.peerDependencies.three).toBeDefined();
  });

  it('plain Node imports it by name and writes a BVH from the shipped models', () => {
    fs.writeFileSync(path.join(app, 'run.mjs'), `
      import { createGenerator, writeBVH } from 'emdm-web';
      import { createCharacter } from 'emdm-web/three';
      const g = await createGenerator({ baseUrl: process.argv[2], backend: 'wasm', worker: false, threads: 1 });
      const m = await g.generate({ prompt: 'a person walks forward', seconds: 2, seed: 1 });
      console.log(JSON.stringify({ frames: m.frames, three: typeof createCharacter, bvh: writeBVH(m, g.skeleton) }));
    `);
    const out = JSON.parse(execFileSync(process.execPath, ['run.mjs', MODELS], { cwd: app, encoding: 'utf8' }).trim().split('\n').pop()!);
    expect(out.frames).toBe(40);
    expect(out.three).toBe('function');
    expect(out.bvh.startsWith('HIERARCHY')).toBe(true);
    expect(out.bvh).toContain('Frames: 40');
  });

  it("a consumer's strict tsc accepts its types", () => {
    fs.writeFileSync(path.join(app, 'main.ts'), `
      import { createGenerator, writeBVH, type GeneratedMotion } from 'emdm-web';
      import { createCharacter } from 'emdm-web/three';
      const g = await createGenerator({ baseUrl: '/models/' });
      const m: GeneratedMotion = await g.generate({ prompt: 'a person walks forward', seconds: 2 });
      export const text: string = writeBVH(m, g.skeleton);
      export const character = createCharacter(g.skeleton);
    `);
    fs.writeFileSync(path.join(app, 'tsconfig.json'), JSON.stringify({
      compilerOptions: { target: 'ES2022', module: 'ESNext', moduleResolution: 'Bundler', strict: true, noEmit: true, skipLibCheck: false,
        erasableSyntaxOnly: true, noUnusedLocals: true, noUnusedParameters: true, lib: ['ES2022', 'DOM'], types: [] },
      files: ['main.ts'],
    }));
    const tsc = path.join(ROOT, 'node_modules', 'typescript', 'bin', 'tsc');
    let out = '';
    try {
      execFileSync(process.execPath, [tsc, '-p', app], { cwd: app, encoding: 'utf8' });
    } catch (e) {
      out = String((e as { stdout?: string }).stdout);
    }
    expect(out).toBe('');
  });
});

describe('emdm-web command', () => {
  const cli = (...args: string[]) => {
    try {
      return { code: 0, out: execFileSync(process.execPath, [path.join(app, 'node_modules', 'emdm-web', pkg.bin['emdm-web']), ...args], { cwd: app, encoding: 'utf8', stdio: 'pipe' }) };
    } catch (e) {
      return { code: (e as { status: number }).status, out: String((e as { stderr: string }).stderr) };
    }
  };

  it('copies ORT\'s browser runtimes with their files.json', () => {
    expect(cli('ort', 'static/ort').code).toBe(0);
    const list = JSON.parse(fs.readFileSync(path.join(app, 'static', 'ort', 'files.json'), 'utf8'));
    expect(Object.keys(list)).toEqual(['ort-wasm-simd-threaded.asyncify.wasm', 'ort-wasm-simd-threaded.wasm']);
    expect(fs.statSync(path.join(app, 'static', 'ort', 'ort-wasm-simd-threaded.wasm')).size).toBe(list['ort-wasm-simd-threaded.wasm'].bytes);
  });

  it('copies a models folder after checking every file, and nothing when one is wrong', () => {
    const src = path.join(tmp, 'models-src');
    fs.mkdirSync(path.join(src, 'text'), { recursive: true });
    const body = Buffer.from('step model bytes');
    fs.writeFileSync(path.join(src, 'text', 'm.onnx'), body);
    const sha256 = createHash('sha256').update(body).digest('hex');
    fs.writeFileSync(path.join(src, 'manifest.json'), JSON.stringify({ schema: 1, files: { 'text/m.onnx': { bytes: body.length, sha256 } } }));
    expect(cli('models', src, 'static/models').code).toBe(0);
    expect(fs.readFileSync(path.join(app, 'static', 'models', 'text', 'm.onnx'))).toEqual(body);
    fs.writeFileSync(path.join(src, 'text', 'm.onnx'), 'changed');
    const bad = cli('models', src, 'static/models2');
    expect(bad.code).toBe(2);
    expect(bad.out.trim().split('\n')).toEqual([expect.stringMatching(/m\.onnx: 7 bytes \/ sha256 differ from .*manifest\.json/)]);
    expect(fs.existsSync(path.join(app, 'static', 'models2'))).toBe(false);
    expect(cli('models', path.join(tmp, 'nowhere'), 'x').out).toMatch(/nowhere\/manifest\.json not found/);
    expect(cli('copy').code).toBe(2);
  });
});

const CHROMIUM = process.env.CHROMIUM_PATH ?? '/usr/bin/chromium';
const VITE = path.join(app, 'node_modules', 'vite', 'bin', 'vite.js');

function freePort(): Promise<number> {
  return new Promise((resolve) => {
    const srv = net.createServer().listen(0, '127.0.0.1', () => {
      const { port } = srv.address() as net.AddressInfo;
      srv.close(() => resolve(port));
    });
  });
}

/** `vite <args>` in the app until it prints its address. */
async function serve(args: string[]): Promise<{ url: string; server: ChildProcess }> {
  const port = await freePort();
  const server = spawn(process.execPath, [VITE, ...args, '--port', String(port), '--strictPort', '--host', '127.0.0.1'], { cwd: app });
  await new Promise<void>((resolve, reject) => {
    let log = '';
    // CI=true turns Vite's colours on, and it prints the port in bold: match the text without escape codes
    server.stdout!.on('data', (d) => { log += d; if (log.replace(/\x1b\[[0-9;]*m/g, '').includes(`:${port}`)) resolve(); });
    server.stderr!.on('data', (d) => { log += d; });
    server.on('exit', (code) => reject(new Error(`vite ${args.join(' ')} exited ${code}: ${log}`)));
    setTimeout(() => reject(new Error(`vite ${args.join(' ')} printed no :${port} in 60 s: ${log}`)), 60_000).unref();
  });
  return { url: `http://127.0.0.1:${port}/`, server };
}

/** Open the page in Chromium and wait for its motion; what a user would see, and every host it asked. */
async function generateIn(url: string) {
  const profile = fs.mkdtempSync(path.join(tmp, 'chromium-'));
  const ctx = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM, headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  try {
    const page = await ctx.newPage();
    const hosts = new Set<string>();
    const failed: string[] = [];
    page.on('request', (r) => hosts.add(new URL(r.url()).host));
    page.on('response', (r) => { if (r.status() >= 400) failed.push(`${r.status()} ${r.url()}`); });
    await page.goto(url);
    const result = await page.evaluate(() => (window as unknown as { result: Promise<unknown> }).result);
    return { result, hosts: [...hosts], failed, isolated: await page.evaluate(() => crossOriginIsolated) };
  } finally {
    await ctx.close();
  }
}

/** `vite <args>` serves the app, and the page generates a motion from its own origin only, cross-origin isolated. */
async function generatesThrough(args: string[]): Promise<void> {
  const { url, server } = await serve(args);
    try {
      const r = await generateIn(url);
      expect(r.result).toEqual({ frames: 40, joints: 40 * 22 * 3 });
      expect(r).toMatchObject({ hosts: [new URL(url).host], failed: [], isolated: true });
    } finally {
      server.kill();
    }
}

describe('Vite app with emdm-web/vite', () => {
  beforeAll(() => {
    fs.writeFileSync(path.join(app, 'index.html'),
      '<!doctype html><html><head><link rel="icon" href="data:,"></head><body><script type="module" src="/main.js"></script></body></html>');
    fs.writeFileSync(path.join(app, 'main.js'), `
      import { createGenerator } from 'emdm-web';
      window.result = (async () => {
        const g = await createGenerator({ threads: 1 });
        const m = await g.generate({ prompt: 'a person walks forward', seconds: 2, seed: 1 });
        return { frames: m.frames, joints: m.joints.length };
      })().catch((e) => ({ error: String((e && e.stack) || e) }));
    `);
    fs.writeFileSync(path.join(app, 'vite.config.js'),
      `import { emdm } from 'emdm-web/vite';\nexport default { plugins: [emdm({ models: ${JSON.stringify(MODELS)} })] };\n`);
  });

  it('its production build generates in Chromium', async () => {
    execFileSync(process.execPath, [VITE, 'build'], { cwd: app, encoding: 'utf8' });
    const dist = path.join(app, 'dist');
    expect(fs.existsSync(path.join(dist, 'models', 'manifest.json'))).toBe(true);
    expect(Object.keys(JSON.parse(fs.readFileSync(path.join(dist, 'ort', 'files.json'), 'utf8')))).toEqual(
      ['ort-wasm-simd-threaded.asyncify.wasm', 'ort-wasm-simd-threaded.wasm']);       // WebGPU's and WASM's runtimes
    expect(fs.readdirSync(path.join(dist, 'assets')).filter((f) => f.endsWith('.wasm'))).toEqual([]);
    await generatesThrough(['preview']);
  }, 240_000);

  it('its dev server generates in Chromium', async () => {
    await generatesThrough([]);
  }, 240_000);
});
