// "Show steps": one small stick figure per denoising step, drawn from that step's prediction x̂0
// (the joints the generation worker sends with each step preview), so the motion can be seen sharpen.

/** Height the thumbnails show (metres, floor at the bottom): one scale for every step, so blur looks like blur. */
export const STRIP_HEIGHT_M = 2.0;

/**
 * The bones of one frame seen from the front (the camera on +z looking at −z, y up, +x to the right),
 * centred on that frame's root (joint 0) horizontally, floor (y = 0) at the bottom, uniform scale.
 * Returns [x1, y1, x2, y2] per bone in canvas pixels (y down), one per joint that has a parent.
 */
export function frontStickFigure(joints: ArrayLike<number>, frames: number, frame: number, parents: readonly number[],
  width: number, height: number, pad = 4): Array<[number, number, number, number]> {
  const J = parents.length;
  if (joints.length !== frames * J * 3) throw new RangeError(`frontStickFigure: joints has ${joints.length} values, expected frames ${frames} × ${J} joints × 3`);
  if (!Number.isInteger(frame) || frame < 0 || frame >= frames) throw new RangeError(`frontStickFigure: frame ${frame} outside 0…${frames - 1}`);
  const base = frame * J * 3;
  const scale = (height - 2 * pad) / STRIP_HEIGHT_M;
  const cx = joints[base];
  const px = (j: number) => width / 2 + (joints[base + j * 3] - cx) * scale;
  const py = (j: number) => height - pad - joints[base + j * 3 + 1] * scale;
  const out: Array<[number, number, number, number]> = [];
  for (let j = 0; j < J; j++) {
    const p = parents[j];
    if (p >= 0) out.push([px(p), py(p), px(j), py(j)]);
  }
  return out;
}

/** The strip under the step slider: cleared when a generation starts, one thumbnail added per step preview. */
export class StepStrip {
  private count = 0;

  constructor(private readonly el: HTMLElement, private readonly parents: readonly number[], private readonly size = { width: 44, height: 64 }) {}

  /** Empty it (hidden) before a generation. */
  reset(): void {
    this.el.replaceChildren();
    this.el.hidden = true;
    this.count = 0;
  }

  /** One step's prediction: its middle frame as a stick figure. */
  add(step: number, steps: number, joints: Float32Array, frames: number): void {
    const { width, height } = this.size;
    const fig = document.createElement('figure');
    fig.className = 'step-thumb';
    fig.dataset.step = String(step);
    const canvas = document.createElement('canvas');
    const dpr = Math.min(2, globalThis.devicePixelRatio || 1);
    canvas.width = Math.round(width * dpr);
    canvas.height = Math.round(height * dpr);
    canvas.style.width = `${width}px`;
    canvas.style.height = `${height}px`;
    canvas.setAttribute('role', 'img');
    canvas.setAttribute('aria-label', `Prediction after denoising step ${step} of ${steps} (middle frame, front view)`);
    const g = canvas.getContext('2d');
    if (g) {
      g.scale(dpr, dpr);
      g.strokeStyle = step === steps ? '#8fb3ff' : '#c9d3e6';
      g.lineWidth = 1.6;
      g.lineCap = 'round';
      g.beginPath();
      for (const [x1, y1, x2, y2] of frontStickFigure(joints, frames, frames >> 1, this.parents, width, height)) {
        g.moveTo(x1, y1);
        g.lineTo(x2, y2);
      }
      g.stroke();
    }
    const cap = document.createElement('figcaption');
    cap.textContent = String(step);
    fig.append(canvas, cap);
    this.el.append(fig);
    this.el.hidden = false;
    this.count++;
    revealInPanel(this.el);
  }

  /** Bring the strip, when shown, into the side panel's view (after a generation: a notice may have pushed it down). */
  reveal(): void {
    if (!this.el.hidden) revealInPanel(this.el);
  }

  get length(): number {
    return this.count;
  }
}

/**
 * Scroll the side panel (#panel, when it scrolls) just enough that `e` shows above the panel's sticky bottom bar
 * (#panel-actions): a notice above the strip (a far prompt's) can push it below the fold of a laptop screen.
 */
function revealInPanel(e: HTMLElement): void {
  const panel = e.closest<HTMLElement>('#panel');
  if (!panel || panel.scrollHeight <= panel.clientHeight) return;
  const bar = document.getElementById('panel-actions');
  const limit = Math.min(panel.getBoundingClientRect().bottom, bar?.getBoundingClientRect().top ?? Infinity);
  const over = e.getBoundingClientRect().bottom - limit;
  if (over > 0) panel.scrollTop += over + 8;
}
