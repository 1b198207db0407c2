/**
 * One denoising step of an exported EMDM generator (ONNX contract in docs/ARCHITECTURE.md):
 * inputs x_t [B,L,263], z [B,64], cond [B,C], t [B], mask [B,L] → x0 [B,L,263].
 */
import type { StepFn, StepInputs } from '../sampler/sampler';
import type { OrtSession } from './ort';

export const STEP_INPUTS = ['x_t', 'z', 'cond', 't', 'mask'] as const;
export const STEP_OUTPUT = 'x0';

export class IncompatibleModelError extends Error {
  constructor(readonly path: string, message: string) {
    super(`${path}: incompatible step model: ${message}`);
    this.name = 'IncompatibleModelError';
  }
}

export interface StepModelShape {
  featureDim: number;
  zDim: number;
  condDim: number;
}

/** Check the session's input/output names against the contract; throws IncompatibleModelError naming what differs. */
export function checkStepSession(session: OrtSession, path: string): void {
  const missing = STEP_INPUTS.filter((n) => !session.inputNames.includes(n));
  const extra = session.inputNames.filter((n) => !(STEP_INPUTS as readonly string[]).includes(n));
  if (missing.length || extra.length) {
    throw new IncompatibleModelError(
      path,
      `inputs are [${session.inputNames.join(', ')}], expected [${STEP_INPUTS.join(', ')}]` +
        (missing.length ? ` (missing ${missing.join(', ')})` : '') +
        (extra.length ? ` (unexpected ${extra.join(', ')})` : ''),
    );
  }
  if (!session.outputNames.includes(STEP_OUTPUT)) {
    throw new IncompatibleModelError(path, `outputs are [${session.outputNames.join(', ')}], expected '${STEP_OUTPUT}'`);
  }
}

/** Wrap a checked session as the sampler's step function. */
export function stepFunction(session: OrtSession, shape: StepModelShape, path: string): StepFn {
  checkStepSession(session, path);
  const { featureDim: D, zDim, condDim: C } = shape;
  return async (i: StepInputs) => {
    const { batch: B, frames: L } = i;
    const out = await session.run({
      x_t: { data: i.x, dims: [B, L, D] },
      z: { data: i.z, dims: [B, zDim] },
      cond: { data: i.cond, dims: [B, C] },
      t: { data: i.t, dims: [B] },
      mask: { data: i.mask, dims: [B, L] },
    });
    const x0 = out[STEP_OUTPUT];
    const want = [B, L, D];
    if (x0.dims.length !== 3 || x0.dims.some((d, k) => d !== want[k])) {
      throw new IncompatibleModelError(path, `output x0 has shape [${x0.dims.join(', ')}], expected [${want.join(', ')}]`);
    }
    return x0.data;
  };
}
