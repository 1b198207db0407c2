// The compare view's pure rules (web/ui/compare.ts) and its URL state (web/ui/state.ts).
import { describe, expect, it } from 'vitest';
import { compareNote, compareStepChoices, planCompare } from '../../web/ui/compare';
import { emdmSteps, parseState, stateToSearch, stepChoices, type StateLimits } from '../../web/ui/state';

const EMDM = [1, 2, 4, 5, 8, 10];
const DDIM = [1, 2, 4, 5, 8, 10, 20, 50, 100];

describe('compare plan', () => {
  it("a timeline, an edit and live mode run EMDM's count for the slider: the compare view's own EMDM side", () => {
    // with the compare view on, the slider offers DDIM's 20/50/100; those requests have no DDIM side and refused them
    for (const n of DDIM) expect(emdmSteps(n, EMDM), `${n}`).toBe(planCompare(n, EMDM, DDIM).emdm);
    expect([20, 50, 100].map((n) => emdmSteps(n, EMDM))).toEqual([10, 10, 10]);
    expect(emdmSteps(3, EMDM)).toBe(2);
    expect(emdmSteps(0, EMDM)).toBe(1);
  });

  it('the slider offers both models\u2019 counts; EMDM stays at its maximum past 10 and says so', () => {
    expect(compareStepChoices({ supportedSteps: EMDM }, { supportedSteps: DDIM })).toEqual(DDIM);
    expect(planCompare(4, EMDM, DDIM)).toEqual({ emdm: 4, ddim: 4, emdmCapped: false });
    expect(planCompare(50, EMDM, DDIM)).toEqual({ emdm: 10, ddim: 50, emdmCapped: true });
    expect(planCompare(100, EMDM, DDIM)).toEqual({ emdm: 10, ddim: 100, emdmCapped: true });
    expect(compareNote(50, planCompare(50, EMDM, DDIM))).toBe('EMDM stays at 10 steps, its maximum (it was trained for few steps).');
    expect(compareNote(10, planCompare(10, EMDM, DDIM))).toMatch(/DDIM needs 50–100 steps/);
    expect(compareNote(50, planCompare(50, EMDM, DDIM))).not.toMatch(/DDIM runs/);
  });

  it('a count one model lacks runs its nearest (EMDM: the largest below), and the note names it', () => {
    const p = planCompare(3, [1, 2, 4], [1, 5, 10]);
    expect(p).toEqual({ emdm: 2, ddim: 5, emdmCapped: false }); // 1 and 5 are equally near: ties go to the larger
    expect(compareNote(3, p)).toBe('EMDM runs 2 steps (it has no 3-step schedule). DDIM runs 5 steps.');
    expect(() => planCompare(3, [], DDIM)).toThrow(/supportedSteps/);
  });
});

describe('compare in the page state', () => {
  const limits: StateLimits = {
    supportedSteps: EMDM, defaultSteps: 10, defaultGuidance: 2.5, actions: ['walk'], fps: 20, maxFrames: 196, defaultText: 'walk',
    compareSteps: DDIM,
  };

  it('compare=1 round-trips through the URL and allows the diffusion model\u2019s step counts', () => {
    const { state, notices } = parseState('?mode=text&text=hi&steps=50&compare=1', limits, 1);
    expect(notices).toEqual([]);
    expect(state).toMatchObject({ compare: true, steps: 50 });
    expect(new URLSearchParams(stateToSearch(state)).get('compare')).toBe('1');
    expect(stepChoices(limits, true)).toEqual(DDIM);
    expect(stepChoices(limits, false)).toEqual(EMDM);
  });

  it('without compare, steps=50 snaps to EMDM\u2019s 10 with a notice; compare=1 without a diffusion model is refused', () => {
    const a = parseState('?steps=50', limits, 1);
    expect(a.state.steps).toBe(10);
    expect(a.notices.join()).toMatch(/steps=50 is not supported/);
    const b = parseState('?compare=1&steps=50', { ...limits, compareSteps: [] }, 1);
    expect(b.state.compare).toBe(false);
    expect(b.state.steps).toBe(10);
    expect(b.notices.join()).toMatch(/no diffusion \(DDIM\) model/);
    const c = parseState('?mode=action&compare=1', limits, 1);
    expect(c.state.compare).toBe(false);
    expect(c.notices.join()).toMatch(/not an action/);
  });
});
