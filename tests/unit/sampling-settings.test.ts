// One SamplingSettings object from createGenerator's request to the sampler: every field a request gives reaches
// the loop as it was given (here `method`, which no other path sets), in-process and through resolveRequest's wire
// options, and the fields it leaves out take the model's manifest values.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { createGenerator } from '../../src/createGenerator';
import { openModel } from '../../src/openModel';
import { loadManifest } from '../../src/manifest';
import { resolveRequest } from '../../src/requests';
import { tinyModels } from './coreFixtures';

const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-settings-'));
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));
const same = (a: Float32Array, b: Float32Array) => Buffer.from(a.buffer, a.byteOffset, a.byteLength).equals(Buffer.from(b.buffer, b.byteOffset, b.byteLength));

describe('SamplingSettings', () => {
  it('resolveRequest carries the request\'s settings and fills steps and guidance from the manifest', async () => {
    const { dir } = tinyModels(tmp);
    const manifest = await loadManifest(dir);
    const given = resolveRequest(manifest, { model: 'tiny', action: 1, method: 'ddim', steps: 2, guidance: 1.5, guidanceMinTime: 0.3, x0Smoothing: 1, seed: 3 }).options;
    expect(given).toMatchObject({ method: 'ddim', steps: 2, guidance: 1.5, guidanceMinTime: 0.3, x0Smoothing: 1 });
    const plain = resolveRequest(manifest, { model: 'tiny', action: 1, seed: 3 }).options;
    expect(plain).toMatchObject({ steps: manifest.models.tiny.defaultSteps, guidance: manifest.models.tiny.guidance });
    expect('method' in plain || 'guidanceMinTime' in plain || 'x0Smoothing' in plain).toBe(false);
  });

  it('a method given to createGenerator\'s generate is the one the sampler runs', async () => {
    const { dir } = tinyModels(tmp);
    const manifest = await loadManifest(dir);
    const g = await createGenerator({ manifest, baseUrl: dir, backend: 'wasm', worker: false, threads: 1 });
    const req = { model: 'tiny', action: 1, frames: 24, steps: 2, guidance: 2.5, seed: 9 };
    const byDefault = await g.generate(req);
    const byDdim = await g.generate({ ...req, method: 'ddim' });
    // the same file declared as a diffusion model samples with DDIM by default: the same motion, bit for bit
    const ddimModel = await openModel({ manifest, baseUrl: dir, model: 'tiny-ddim', backend: 'wasm', threads: 1 });
    const reference = await ddimModel.generate({ condition: { type: 'action', label: 1 }, frames: 24, steps: 2, guidance: 2.5, seed: 9 });
    expect(reference.sampler).toBe('ddim');
    expect(same(byDdim.features, reference.motion.features)).toBe(true);
    expect(same(byDefault.features, byDdim.features)).toBe(false);
    await Promise.all([g.dispose(), ddimModel.dispose()]);
  });
});
