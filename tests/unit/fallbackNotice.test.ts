// The page tells the visitor once per reason that a model falls back from WebGPU to WASM (web/ui/engine.ts):
// without a GPU the text, action and diffusion models all fall back for the same reason.
import { describe, expect, it } from 'vitest';
import { oncePerReason } from '../../web/ui/engine';

describe('oncePerReason', () => {
  it('passes the first model of each reason and drops repeats', () => {
    const said: string[] = [];
    const f = oncePerReason((model, reason) => said.push(`${model}: ${reason}`));
    f('emdm-t2m-web', 'WebGPU is not available (no usable GPU adapter)');
    f('diffusion-t2m-web', 'WebGPU is not available (no usable GPU adapter)');
    f('emdm-a2m-web', 'WebGPU is not available (no usable GPU adapter)');
    f('emdm-a2m-web', 'WebGPU failed at run time: device lost');
    expect(said).toEqual([
      'emdm-t2m-web: WebGPU is not available (no usable GPU adapter)',
      'emdm-a2m-web: WebGPU failed at run time: device lost',
    ]);
  });
});
