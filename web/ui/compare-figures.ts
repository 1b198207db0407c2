// The compare view's small chart of what the steps change: jerk and foot skate of the two motions on screen
// (web/ui/motion-figures.ts), in the table #compare-figures of the rail, each figure with a bar scaled to the larger
// of its row (the bars are drawing only: the numbers are the table's text).
import { byId } from './dom';
import { motionFigures, type MotionFigures } from './motion-figures';

interface ShownMotion { joints: ArrayLike<number>; frames: number; fps: number }

/** A figure as the table shows it: 3 significant figures, '–' when it cannot be measured. */
export function formatFigure(v: number): string {
  if (!Number.isFinite(v)) return '–';
  return v >= 100 ? v.toFixed(0) : v >= 10 ? v.toFixed(1) : v.toFixed(2);
}

/** Fill the table from the EMDM (left) and DDIM (right) motions. */
export function showFigures(emdm: ShownMotion, ddim: ShownMotion): void {
  const figs = { emdm: motionFigures(emdm.joints, emdm.frames, emdm.fps), ddim: motionFigures(ddim.joints, ddim.frames, ddim.fps) };
  for (const [row, key] of [['jerk', 'jerk'], ['skate', 'footSkate']] as const) {
    const top = Math.max(figs.emdm[key] || 0, figs.ddim[key] || 0);
    for (const side of ['emdm', 'ddim'] as const) fillCell(byId(`fig-${side}-${row}`), figs[side], key, top);
  }
}

function fillCell(td: HTMLElement, f: MotionFigures, key: keyof MotionFigures, top: number): void {
  const v = f[key];
  const bar = document.createElement('span');
  bar.className = 'fig-bar';
  bar.setAttribute('aria-hidden', 'true');
  bar.style.width = `${top > 0 && Number.isFinite(v) ? Math.max(2, (100 * v) / top) : 0}%`;
  td.replaceChildren(document.createTextNode(formatFigure(v)), bar);
  td.dataset.value = String(v);
}
