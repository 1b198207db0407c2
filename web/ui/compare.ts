// The compare view's rules (pure): which model runs at which step count for one slider value, and
// the label of each panel. EMDM (a few-step DDGAN model) is trained for at most 10 steps; the plain
// diffusion baseline sampled with DDIM needs 50–100 for quality, so the compare slider goes further
// and EMDM stays at its maximum there (and says so).
import type { ModelEntry } from '../../src/index';

export interface ComparePlan {
  /** steps EMDM runs (its largest supported count ≤ the slider, else its smallest) */
  emdm: number;
  /** steps DDIM runs (the slider value when the diffusion model supports it, else its nearest) */
  ddim: number;
  /** the slider asked EMDM for more steps than it was trained for */
  emdmCapped: boolean;
}

/** Merged, sorted step counts of the two models (the compare slider's choices). */
export function compareStepChoices(emdm: Pick<ModelEntry, 'supportedSteps'>, ddim: Pick<ModelEntry, 'supportedSteps'>): number[] {
  return [...new Set([...emdm.supportedSteps, ...ddim.supportedSteps])].sort((a, b) => a - b);
}

export function planCompare(steps: number, emdmSteps: number[], ddimSteps: number[]): ComparePlan {
  if (!emdmSteps.length || !ddimSteps.length) throw new Error('compare: both models need supportedSteps');
  const e = [...emdmSteps].sort((a, b) => a - b);
  const below = e.filter((s) => s <= steps);
  const emdm = below.length ? below[below.length - 1] : e[0];
  let ddim = ddimSteps[0];
  for (const s of ddimSteps) if (Math.abs(s - steps) < Math.abs(ddim - steps) || (Math.abs(s - steps) === Math.abs(ddim - steps) && s > ddim)) ddim = s;
  return { emdm, ddim, emdmCapped: steps > e[e.length - 1] };
}

/** The note under the slider in compare mode ('' when both run the slider's value). */
export function compareNote(steps: number, plan: ComparePlan): string {
  const parts: string[] = [];
  if (plan.emdmCapped) parts.push(`EMDM stays at ${plan.emdm} steps, its maximum (it was trained for few steps).`);
  else if (plan.emdm !== steps) parts.push(`EMDM runs ${plan.emdm} steps (it has no ${steps}-step schedule).`);
  if (plan.ddim !== steps) parts.push(`DDIM runs ${plan.ddim} steps.`);
  if (!parts.length && steps < 20) parts.push('DDIM needs 50–100 steps for good motion: try them.');
  return parts.join(' ');
}
