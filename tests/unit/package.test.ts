// The npm package as a new user gets it: `npm pack` (prepack builds dist-lib/ with scripts/build/build-lib.mjs),
// the tarball unpacked as node_modules/emdm-web of a scratch folder outside the checkout (its dependencies and the
// three peer linked from this checkout's node_modules: no registry needed), then
// - plain Node imports 'emdm-web' and 'emdm-web/three' by name and generates a BVH from the shipped models;
// - a consumer's strict tsc (erasableSyntaxOnly, no unused locals/parameters, skipLibCheck off) accepts its types;
// - three (a peer) at the lowest and the highest version of the declared range, each in a scratch app of its own (the
//   lowest installed from the npm registry with its @types/three and three-vrm): plain Node makes a character, loads a
//   glTF and a VRM character, retargets a motion and writes its GLB, and the strict tsc accepts the types;
// - the tarball holds the built library, not models, tests, sources or the Python pipeline, and is under 5 MB;
// - `emdm-web models|ort` copies a verified models folder / ORT's browser runtimes into an app's static folder;
// - a Vite app whose only wiring is `emdm({ models })` from 'emdm-web/vite' generates a motion in Chromium, from
//   its production build (vite build + vite preview) and its dev server, cross-origin isolated, fetching nothing
//   from another host, its dist/ holding one ONNX Runtime .wasm (ort/ort-wasm-simd-threaded.wasm: the plugin adds
//   WebGPU's only with `webgpu: true`, tests/unit/backendChoice.test.ts) and no 404 (the library asks for no
//   runtime the app does not serve).
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

function link(name: string, into = app): void {
  const to = path.join(into, 'node_modules', name);
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
    const docs = (f: string) => /^docs\/[A-Z]+\.md$/.test(f) || /^web\/examples\/minimal\.(html|css)$/.test(f);
    expect(files.filter((f) => !f.startsWith('dist-lib/') && !docs(f) && !['package.json', 'LICENSE', 'README.md', 'CHANGELOG.md'].includes(f))).toEqual([]);
    expect(files.filter((f) => /\.(onnx|pt|f32|py)$/.test(f) || (f.endsWith('.ts') && !f.endsWith('.d.ts')))).toEqual([]);
    expect(pkg.private).toBeUndefined();
    expect(pkg.dependencies.three).toBeUndefined();
    expect(pkg.peerDependencies.three).toBeDefined();
  });

  it("its README's links lead somewhere inside the package (the docs, the minimal page, their sections)", () => {
    const target = path.join(app, 'node_modules', 'emdm-web');
    const readme = fs.readFileSync(path.join(target, 'README.md'), 'utf8');
    const links = [...readme.matchAll(/\]\(([^)\s]+)\)/g)].map((m) => m[1]).filter((u) => !/^(https?:|mailto:|#)/.test(u));
    expect(links.length).toBeGreaterThan(5);
    // GitHub's heading anchors: lower case, punctuation dropped, spaces as hyphens
    const slug = (h: string) => h.trim().toLowerCase().replace(/[^\p{L}\p{N}\s_-]/gu, '').replace(/\s/g, '-');
    const broken = links.filter((u) => {
      const [file, anchor] = u.split('#');
      const at = path.join(target, file);
      if (!fs.existsSync(at)) return true;
      if (!anchor) return false;
      const heads = [...fs.readFileSync(at, 'utf8').matchAll(/^#+ (.+)$/gm)].map((m) => slug(m[1]));
      return !heads.includes(anchor);
    });
    expect(broken).toEqual([]);
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
    expect(strictTsc(app)).toBe('');
  });
});

/** What a consumer's strict tsc (skipLibCheck off) says of a module using the package's typed API in `dir` ('' = no error). */
function strictTsc(dir: string): string {
  fs.writeFileSync(path.join(dir, 'main.ts'), `
    import { characterToGLB, createGenerator, loadCharacter, retargetMotion, writeBVH, type GeneratedMotion } from 'emdm-web';
    import { createCharacter } from 'emdm-web/three';
    const g = await createGenerator({ baseUrl: '/models/' });
    const m: GeneratedMotion = await g.generate({ prompt: 'a person walks forward', seconds: 2 });
    export const text: string = writeBVH(m, g.skeleton);
    export const character = createCharacter(g.skeleton);
    const ch = await loadCharacter([{ name: 'a.glb', data: new Uint8Array(8) }]);
    export const glb: Uint8Array = characterToGLB(ch, retargetMotion(ch.root, ch.mapping, m, g.skeleton));
  `);
  fs.writeFileSync(path.join(dir, 'tsconfig.json'), JSON.stringify({
    compilerOptions: { target: 'ES2022', module: 'ESNext', moduleResolution: 'Bundler', strict: true, noEmit: true, skipLibCheck: false,
      erasableSyntaxOnly: true, noUnusedLocals: true, noUnusedParameters: true, lib: ['ES2022', 'DOM'], types: [] },
    files: ['main.ts'],
  }));
  const tsc = path.join(ROOT, 'node_modules', 'typescript', 'bin', 'tsc');
  try {
    execFileSync(process.execPath, [tsc, '-p', dir], { cwd: dir, encoding: 'utf8' });
    return '';
  } catch (e) {
    return String((e as { stdout?: string }).stdout);
  }
}

/** A scratch app with a copy of the package and three `version` (with its @types/three and three-vrm): the
 * development version linked from this checkout, another installed from the npm registry. */
function appWithThree(version: string): string {
  const dir = path.join(tmp, `three-${version}`);
  if (fs.existsSync(dir)) return dir;
  fs.mkdirSync(dir, { recursive: true });
  fs.writeFileSync(path.join(dir, 'package.json'), JSON.stringify({ name: 'app-three', type: 'module', private: true }));
  if (version === pkg.devDependencies.three) {
    for (const name of ['three', '@types/three', '@pixiv/three-vrm']) link(name, dir);
  } else {
    execFileSync('npm', ['install', '--no-audit', '--no-fund', '--ignore-scripts', '--prefer-offline', `three@${version}`, `@types/three@~${version}`,
      `@pixiv/three-vrm@${pkg.dependencies['@pixiv/three-vrm']}`], { cwd: dir, encoding: 'utf8', stdio: 'pipe' });
  }
  // a copy, not a link: the package resolves 'three' from where it lies
  fs.cpSync(path.join(app, 'node_modules', 'emdm-web'), path.join(dir, 'node_modules', 'emdm-web'), { recursive: true });
  for (const name of ['onnxruntime-web', '@huggingface/transformers']) link(name, dir);
  return dir;
}

const THREE_RANGE = /^>=(0\.\d+\.\d+) <0\.(\d+)\.0$/;

describe('three, the peer dependency', () => {
  const [, lowest, next] = THREE_RANGE.exec(pkg.peerDependencies.three) ?? [];
  const highest: string = pkg.devDependencies.three;

  it('is declared as the range tested here: from its lowest version to the development one', () => {
    expect(pkg.peerDependencies.three).toMatch(THREE_RANGE);
    expect(Number(next)).toBe(Number(highest.split('.')[1]) + 1);      // nothing newer than what is tested
    expect(pkg.peerDependencies['@types/three']).toBe(pkg.peerDependencies.three);
    expect(pkg.devDependencies['@types/three']).toBe(highest);
  });

  for (const [which, version] of [['lowest', lowest], ['highest', highest]]) {
    it(`three ${version} (the ${which}): Node makes, loads, retargets and exports characters; strict tsc accepts the types`, () => {
      const dir = appWithThree(version);
      fs.writeFileSync(path.join(dir, 'run.mjs'), `
        import fs from 'node:fs';
        import { Box3, REVISION, Vector3 } from 'three';
        import { characterToGLB, createGenerator, loadCharacter, retargetMotion } from 'emdm-web';
        import { createCharacter } from 'emdm-web/three';
        const [models, rigs] = process.argv.slice(2);
        const g = await createGenerator({ baseUrl: models, backend: 'wasm', worker: false, threads: 1 });
        const m = await g.generate({ prompt: 'a person walks forward', seconds: 2, seed: 1 });
        const c = createCharacter(g.skeleton);
        c.play(m);
        const hips = () => (c.object.updateMatrixWorld(true), c.bones[0].getWorldPosition(new Vector3()));
        const start = hips();
        c.update(1.5);
        const box = new Box3().setFromObject(c.object, true);
        const read = (name) => loadCharacter([{ name, data: new Uint8Array(fs.readFileSync(rigs + '/' + name)) }]);
        const robot = await read('RobotExpressive.glb');
        const vrm = await read('cryptovoxels.vrm');
        const r = retargetMotion(robot.root, robot.mapping, m, g.skeleton);
        const glb = characterToGLB(robot, r);
        console.log(JSON.stringify({ three: REVISION, walked: hips().distanceTo(start), height: box.max.y - box.min.y,
          robot: robot.mappingSource, vrm: vrm.mappingSource, finite: r.rotations.every((q) => q.every(Number.isFinite)),
          glb: new TextDecoder().decode(glb.subarray(0, 4)) }));
      `);
      const out = JSON.parse(execFileSync(process.execPath, ['run.mjs', MODELS, path.join(ROOT, 'tests', 'fixtures', 'rigs')],
        { cwd: dir, encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] }).trim().split('\n').pop()!);
      expect(out).toMatchObject({ three: version.split('.')[1], robot: 'names', vrm: 'vrm', finite: true, glb: 'glTF' });
      expect(out.walked).toBeGreaterThan(0.5);           // 1.5 s of a walk moved the hips
      expect(out.height).toBeGreaterThan(1.4);           // a standing person's size, posed
      expect(out.height).toBeLessThan(2.1);
      expect(strictTsc(dir)).toBe('');
    }, 240_000);
  }
});

describe('emdm-web command', () => {
  const cli = (...args: string[]) => {
    try {
      return { code: 0, out: execFileSync(process.execPath, [path.join(app, 'node_modules', 'emdm-web', pkg.bin['emdm-web']), ...args], { cwd: app, encoding: 'utf8', stdio: 'pipe' }) };
    } catch (e) {
      return { code: (e as { status: number }).status, out: String((e as { stderr: string }).stderr) };
    }
  };

  it('copies ORT\'s WASM runtime with its files.json, and WebGPU\'s too with --webgpu', () => {
    const wasmIn = (dir: string) => fs.readdirSync(path.join(app, dir)).filter((f) => f.endsWith('.wasm')).sort();
    expect(cli('ort', 'static/ort').code).toBe(0);
    const list = JSON.parse(fs.readFileSync(path.join(app, 'static', 'ort', 'files.json'), 'utf8'));
    expect(Object.keys(list)).toEqual(['ort-wasm-simd-threaded.wasm']);
    expect(wasmIn('static/ort')).toEqual(['ort-wasm-simd-threaded.wasm']);
    expect(fs.statSync(path.join(app, 'static', 'ort', 'ort-wasm-simd-threaded.wasm')).size).toBe(list['ort-wasm-simd-threaded.wasm'].bytes);
    expect(cli('ort', '--webgpu', 'static/ort-gpu').code).toBe(0);
    expect(Object.keys(JSON.parse(fs.readFileSync(path.join(app, 'static', 'ort-gpu', 'files.json'), 'utf8')))).toEqual(
      ['ort-wasm-simd-threaded.asyncify.wasm', 'ort-wasm-simd-threaded.wasm']);
    expect(wasmIn('static/ort-gpu')).toEqual(['ort-wasm-simd-threaded.asyncify.wasm', 'ort-wasm-simd-threaded.wasm']);
    const bad = cli('ort', 'static/x', '--webgpuu');
    expect(bad.code).toBe(2);
    expect(bad.out.trim().split('\n')).toEqual([expect.stringContaining('emdm-web ort <dest> [--webgpu]')]);
  });

  it('copies a models folder after checking every file, and nothing when one is wrong', () => {
    const src = path.join(tmp, 'models-src');
    fs.mkdirSync(path.join(src, 'text'), { recursive: true });
    const body = Buffer.from('step model bytes');
    fs.writeFileSync(path.join(src, 'text', 'm.onnx'), body);
    const sha256 = createHash('sha256').update(body).digest('hex');
    // a model's training weights (PyTorch, for the next training run) are listed but no browser loads them: left behind
    fs.writeFileSync(path.join(src, 'm.weights.f16.pt'), body);
    fs.writeFileSync(path.join(src, 'manifest.json'), JSON.stringify({ schema: 1, models: { m: { trainingWeights: 'm.weights.f16.pt' } },
      files: { 'text/m.onnx': { bytes: body.length, sha256 }, 'm.weights.f16.pt': { bytes: body.length, sha256 } } }));
    expect(cli('models', src, 'static/models').code).toBe(0);
    expect(fs.readFileSync(path.join(app, 'static', 'models', 'text', 'm.onnx'))).toEqual(body);
    expect(fs.existsSync(path.join(app, 'static', 'models', 'm.weights.f16.pt'))).toBe(false);
    expect(fs.existsSync(path.join(app, 'static', 'models', 'LICENSE.md'))).toBe(false);        // none in this folder
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
    const served = fs.readdirSync(path.join(dist, 'models'));
    expect(served).toContain('emdm-t2m-web.int8.onnx');
    expect(served.filter((f) => f.endsWith('.pt'))).toEqual([]);        // training weights stay behind (22 MB)
    expect(fs.readFileSync(path.join(dist, 'models', 'LICENSE.md'), 'utf8')).toContain('CC BY-NC 4.0');   // their terms go along
    // ONE ONNX Runtime .wasm (WASM's; WebGPU's only with emdm({ webgpu: true })), listed in files.json
    expect(Object.keys(JSON.parse(fs.readFileSync(path.join(dist, 'ort', 'files.json'), 'utf8')))).toEqual(['ort-wasm-simd-threaded.wasm']);
    const wasm = fs.readdirSync(dist, { recursive: true, encoding: 'utf8' }).filter((f) => f.endsWith('.wasm')).map((f) => f.split(path.sep).join('/'));
    console.log(`consumer dist .wasm: ${wasm.map((f) => `${f} (${fs.statSync(path.join(dist, f)).size} bytes)`).join(', ')}`);
    expect(wasm).toEqual(['ort/ort-wasm-simd-threaded.wasm']);
    await generatesThrough(['preview']);
  }, 240_000);

  it('its dev server generates in Chromium', async () => {
    await generatesThrough([]);
  }, 240_000);
});
