// The compare view's small chart of what the steps change: jerk, foot skate and speed of the two motions on screen
// (web/ui/motion-figures.ts), in the table #compare-figures of the rail, each figure with a bar scaled to the larger
// of its row (the bars are drawing only: the numbers are the table's text). Beside each speed, the real clips' range
// of the prompt's nearest action (the capabilities file's realSpeed, the action from the prompt check) when the
// check knows the prompt.
import type { Capabilities, PromptCheck, RealSpeed } from '../../src/capabilities';
import { byId } from './dom';
import { motionFigures, type MotionFigures } from './motion-figures';

interface ShownMotion { joints: ArrayLike<number>; frames: number; fps: number }

/** A figure as the table shows it: 3 significant figures, '–' when it cannot be measured. */
export function formatFigure(v: number): string {
  if (!Number.isFinite(v)) return '–';
  return v >= 100 ? v.toFixed(0) : v >= 10 ? v.toFixed(1) : v.toFixed(2);
}

/** The real clips' speed of the prompt's nearest action: only for a prompt the check knows, of an action with clips. */
export function realSpeedOf(caps: Capabilities | null, check: PromptCheck | undefined): { action: string; speed: RealSpeed } | null {
  if (!caps || !check?.known) return null;
  const speed = caps.actions.find((a) => a.label === check.action)?.realSpeed;
  return speed ? { action: check.action, speed } : null;
}

/** "real walk 0.55–1.43" */
export function realSpeedNote(r: { action: string; speed: RealSpeed }): string {
  return `real ${r.action.replace(/[_-]+/g, ' ')} ${formatFigure(r.speed.low)}–${formatFigure(r.speed.high)}`;
}

/** Fill the table from the EMDM (left) and DDIM (right) motions; `real`: the speed range to show beside each. */
export function showFigures(emdm: ShownMotion, ddim: ShownMotion, real: { action: string; speed: RealSpeed } | null = null): void {
  const figs = { emdm: motionFigures(emdm.joints, emdm.frames, emdm.fps), ddim: motionFigures(ddim.joints, ddim.frames, ddim.fps) };
  for (const [row, key] of [['jerk', 'jerk'], ['skate', 'footSkate'], ['speed', 'speed']] as const) {
    const top = Math.max(figs.emdm[key] || 0, figs.ddim[key] || 0);
    for (const side of ['emdm', 'ddim'] as const) {
      const td = byId(`fig-${side}-${row}`);
      fillCell(td, figs[side], key, top);
    }
  }
  // the real clips' range on a row of its own, under both speeds (beside each, it made the table wider than the rail)
  byId('fig-real').textContent = real ? `${realSpeedNote(real)} m/s (5th–95th percentile of its clips)` : '';
  byId('fig-real-row').hidden = !real;
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
