// The "Last generation" panel's figures (#timings, web/ui/view.ts shows them). Pure: what ran says what it took;
// when nothing was generated (an unchanged timeline shown again, a live recording) it says so instead of zeros.
import type { GenerateResult } from '../../src/openModel';
import { formatMs } from './dom';

export interface TimingCells {
  encode: string;
  step: string;
  decode: string;
  total: string;
  backend: string;
  calls: string;
}

/** The panel's cells for a result (`ikMs`: the IK solve, when `totalMs` does not hold it). */
export function timingCells(r: Pick<GenerateResult, 'timings' | 'modelCalls'>, ikMs: number): TimingCells {
  const t = r.timings;
  const backend = t.backend === 'webgpu' ? 'WebGPU' : 'WASM';
  // threads is 0 when no window reported it (nothing ran): no "0 threads"
  const threads = t.threads > 0 ? ` · ${t.threads} thread${t.threads === 1 ? '' : 's'}` : '';
  const decode = t.decodeMs + ikMs;
  if (!t.stepMs.length && !r.modelCalls) {
    return { encode: '–', step: 'none: nothing was regenerated', decode: decode > 0 ? formatMs(decode) : '–', total: formatMs(t.totalMs + ikMs), backend: backend + threads, calls: '0' };
  }
  const mean = t.stepMs.length ? t.stepMs.reduce((a, b) => a + b, 0) / t.stepMs.length : NaN;
  // a timeline's windows ran their early steps together before these (counted in the calls, timed apart)
  const begun = r.modelCalls - t.stepMs.length;
  return {
    encode: formatMs(t.encodeMs), step: `${formatMs(mean)} × ${t.stepMs.length}${begun > 0 ? ` (and ${begun} begun together)` : ''}`, decode: formatMs(decode),
    total: formatMs(t.totalMs + ikMs), backend: backend + threads, calls: String(r.modelCalls),
  };
}
