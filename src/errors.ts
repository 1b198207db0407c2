/**
 * Errors of the library that are not about files (those are ModelFileError, src/manifest.ts).
 *
 *     try { await gen.generate(opts); }
 *     catch (e) { if (e instanceof NonFiniteMotionError) keepTheLastGoodMotion(); }
 */

/** A motion (model output, decoded joints, solved rotations) holds NaN or ±Infinity: it is never returned. */
export class NonFiniteMotionError extends Error {
  constructor(
    /** what held the bad number, e.g. "model emdm-t2m-web (emdm-t2m-web.onnx) output features" */
    readonly source: string,
    /** index of the first bad value */
    readonly index: number,
    readonly count: number,
    readonly value: number,
  ) {
    super(`${source}: non-finite numbers (value ${index} of ${count} is ${value}); nothing was returned`);
    this.name = 'NonFiniteMotionError';
  }
}

/** Throw NonFiniteMotionError naming `source` when `values` holds NaN or ±Infinity. */
export function assertFinite(values: ArrayLike<number>, source: string): void {
  for (let i = 0; i < values.length; i++) {
    if (!Number.isFinite(values[i])) throw new NonFiniteMotionError(source, i, values.length, values[i]);
  }
}
