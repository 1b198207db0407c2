// The page's example chips (web/ui/examples.ts) come from the coverage benchmark: every chip the shipped
// text model gets is a prompt that `python -m emdm.eval.coverage` measured as recognised in ≥ 75 % of its
// motions at the model's default steps (docs/results/json/coverage-emdm-t2m-web.json), and the benchmark's
// plain label prompts (scripts/emdm/eval/prompts.json) are the page's own phrasing of the labels.
import { describe, expect, it } from 'vitest';
import fs from 'node:fs';
import path from 'node:path';
import type { Manifest } from '../../src/manifest';
import { examplePrompts, labelToPrompt } from '../../web/ui/examples';

const ROOT = path.resolve(__dirname, '../..');
const read = (rel: string) => JSON.parse(fs.readFileSync(path.join(ROOT, rel), 'utf8'));

interface PromptRate { action: string; n: number; rate: number }
interface Coverage {
  task: string;
  default_steps: number;
  thresholds: { chip: number };
  runs: { steps: number; prompts?: Record<string, PromptRate> }[];
}

const manifest = read('public/models/manifest.json') as Manifest;
const coverage = read('docs/results/json/coverage-emdm-t2m-web.json') as Coverage;
const prompts = read('scripts/emdm/eval/prompts.json') as { actions: Record<string, { plain: string }> };
const condition = manifest.models['emdm-a2m-web'].condition;
const labels = condition.type === 'action' ? condition.labels : [];

describe('example chips', () => {
  it('every chip of the shipped page is a prompt the benchmark passed at the default steps', () => {
    const steps = manifest.models['emdm-t2m-web'].defaultSteps;
    expect(coverage.task).toBe('coverage');
    expect(coverage.default_steps).toBe(steps);
    const run = coverage.runs.find((r) => r.steps === steps);
    expect(run?.prompts, `coverage-emdm-t2m-web.json has no per-prompt run at ${steps} steps`).toBeDefined();
    const chips = examplePrompts(manifest, 'emdm-t2m-web', labels);
    expect(chips.length).toBeGreaterThan(0);
    for (const chip of chips) {
      const measured = run!.prompts![chip];
      expect(measured, `chip "${chip}" was not measured by the benchmark`).toBeDefined();
      expect(measured.rate, `chip "${chip}": recognised in ${measured.rate} of ${measured.n} motions`)
        .toBeGreaterThanOrEqual(coverage.thresholds.chip);
      expect(coverage.thresholds.chip).toBeGreaterThanOrEqual(0.75);
    }
  });

  it('every chip\u2019s motions at the page\u2019s settings move, and its action is covered (the capabilities file)', () => {
    // the realism result the shipped capabilities file took its moving shares from: the page's file, steps, guidance
    const caps = read('public/models/capabilities-emdm-t2m-web.json') as {
      movingSource: string; thresholds: { moving: number }; actions: { label: string; covered: boolean }[];
    };
    const realism = read(caps.movingSource) as { model: string; generated: { prompts: Record<string, { action: string; moving?: number }> } };
    expect(realism.model).toBe('emdm-t2m-web');
    for (const chip of examplePrompts(manifest, 'emdm-t2m-web', labels)) {
      const p = realism.generated.prompts[chip];
      expect(p, `chip "${chip}" was not measured by the realism benchmark`).toBeDefined();
      expect(p.moving, `chip "${chip}": share of its motions that move`).toBeGreaterThanOrEqual(caps.thresholds.moving);
      expect(caps.actions.find((a) => a.label === p.action)?.covered, `chip "${chip}" (${p.action}) covered`).toBe(true);
    }
  });

  it('the benchmark\u2019s plain prompts are the page\u2019s phrasing of every label', () => {
    expect(Object.keys(prompts.actions).sort()).toEqual([...labels].sort());
    for (const label of labels) expect(prompts.actions[label].plain, label).toBe(labelToPrompt(label));
  });
});
