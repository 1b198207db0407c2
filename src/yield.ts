/**
 * Giving the event loop a turn between slices of long work (the sampler's steps, retargeting's frames),
 * so a page keeps drawing and handling input. One module for both; no dependency on the runtime.
 */

const isNode = typeof process !== 'undefined' && !!process.versions?.node && typeof window === 'undefined';

/** Resolve after one macrotask (a MessageChannel message: no 4 ms timer clamp); Node: setImmediate. */
export function yieldToEventLoop(): Promise<void> {
  if (isNode) return new Promise((r) => setImmediate(r));
  return new Promise((resolve) => {
    const ch = new MessageChannel();
    ch.port1.onmessage = () => {
      ch.port1.close();
      resolve();
    };
    ch.port2.postMessage(null);
  });
}

/**
 * A user-visible-priority task (scheduler.postTask) where there is one, so a frame that is due is drawn and
 * input is handled before the next slice; else yieldToEventLoop (Node, older browsers).
 */
export function nextTask(): Promise<void> {
  const sched = (globalThis as { scheduler?: { postTask?: (cb: () => void, o: { priority: string }) => Promise<void> } }).scheduler;
  if (typeof sched?.postTask === 'function') return sched.postTask(() => undefined, { priority: 'user-visible' });
  return yieldToEventLoop();
}
