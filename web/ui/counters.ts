// What the page's session counts (web/ui/session.ts increments them; the test API shows them as
// `window.emdm.counters`, web/ui/testapi.ts).

export interface Counters {
  /** generations requested (UI or API) */
  requests: number;
  /** generations that finished and are on screen */
  generations: number;
  /** generations cancelled because a newer one started */
  cancelled: number;
  /** generations that failed (bad model output, load errors) */
  errors: number;
  /** ONNX step-model calls of finished generations (a guided step batches both passes in one call) */
  modelCalls: number;
  /** denoising steps run, including those of cancelled generations */
  stepsRun: number;
}

export function emptyCounters(): Counters {
  return { requests: 0, generations: 0, cancelled: 0, errors: 0, modelCalls: 0, stepsRun: 0 };
}
