// createGenerator's `variant` (issue 13 item 4): the int8 file of a shipped model runs through the same
// path as openModel's variant (same motion bit for bit), differs from the fp32 file, and a variant the
// manifest does not list is refused naming the ones it has. Without `variant` the entry's defaultVariant runs
// (the shipped EMDM models: int8); 'fp32' asks for the fp32 file.
import fs from 'node:fs';
import path from 'node:path';
import { describe, expect, it } from 'vitest';
import { createGenerator } from '../../src/createGenerator';
import { openModel } from '../../src/openModel';
import { loadManifest } from '../../src/manifest';
import { MODELS_DIR } from './coreFixtures';

const shipped = fs.existsSync(path.join(MODELS_DIR, 'manifest.json'));

describe.skipIf(!shipped)('createGenerator variant (shipped action model)', () => {
  it("runs the manifest's int8 file: the same motion as openModel's int8, not the fp32 one; unknown variants are refused", async () => {
    const manifest = await loadManifest(MODELS_DIR);
    const model = 'emdm-a2m-web';
    const req = { model, action: 'walk', frames: 40, steps: 2, seed: 11 };
    const int8 = await createGenerator({ baseUrl: MODELS_DIR, backend: 'wasm', threads: 1, worker: false, variant: 'int8' });
    const fp32 = await createGenerator({ baseUrl: MODELS_DIR, backend: 'wasm', threads: 1, worker: false, variant: 'fp32' });
    const dflt = await createGenerator({ baseUrl: MODELS_DIR, backend: 'wasm', threads: 1, worker: false });
    const a = await int8.generate(req);
    const b = await fp32.generate(req);
    const d = await dflt.generate(req);
    expect(manifest.models[model].defaultVariant).toBe('int8');
    expect(Buffer.from(d.joints.buffer).equals(Buffer.from(a.joints.buffer))).toBe(true);
    const label = (manifest.models[model].condition as { labels: string[] }).labels.indexOf('walk');
    const ref = await openModel({ manifest, baseUrl: MODELS_DIR, model, variant: 'int8', backend: 'wasm', threads: 1 });
    const want = await ref.generate({ condition: { type: 'action', label }, frames: 40, steps: 2, guidance: manifest.models[model].guidance, seed: 11 });
    expect(Buffer.from(a.joints.buffer).equals(Buffer.from(want.motion.joints.buffer))).toBe(true);
    expect(Buffer.from(a.joints.buffer).equals(Buffer.from(b.joints.buffer))).toBe(false);
    const bad = await createGenerator({ baseUrl: MODELS_DIR, backend: 'wasm', threads: 1, worker: false, variant: 'fp8' });
    await expect(bad.generate(req)).rejects.toThrow(/model 'emdm-a2m-web' has no 'fp8' file \(its variants: int8, fp16\)/);
    await Promise.all([int8.dispose(), fp32.dispose(), dflt.dispose(), bad.dispose(), ref.dispose()]);
  }, 300_000);
});
