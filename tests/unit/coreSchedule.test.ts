import fs from 'node:fs';
import path from 'node:path';
import { describe, expect, it } from 'vitest';
import { computeSchedule, scheduleFor } from '../../src/sampler/schedule';
import { MODELS_DIR } from './coreFixtures';

// The T = 10 test vector of ../shared/GUIDE.md §2 (6 decimals).
const GUIDE_T10 = {
  coef1: [1, 0.733296, 0.533459, 0.395428, 0.285253, 0.192545, 0.11844, 0.065528, 0.032485, 0.014439],
  coef2: [0, 0.262413, 0.44036, 0.527752, 0.555806, 0.544621, 0.511321, 0.46941, 0.426843, 0.386898],
  sigma: [0, 0.285732, 0.475748, 0.617243, 0.721643, 0.795265, 0.845178, 0.879156, 0.903482, 0.92197],
};

describe('schedule', () => {
  it('equals the GUIDE T=10 posterior coefficients', () => {
    const s = computeSchedule(10);
    for (const key of ['coef1', 'coef2', 'sigma'] as const) {
      GUIDE_T10[key].forEach((v, k) => expect(s[key][k], `${key}[${k}]`).toBeCloseTo(v, 5));
    }
    expect(s.time[0]).toBeCloseTo(0.1 * 0.999 + 0.001, 12);
    expect(s.time[9]).toBeCloseTo(1, 12);
  });

  it('is a valid posterior for every step count: sigma[0] = 0, coefficients positive', () => {
    for (const T of [1, 2, 4, 5, 8, 10, 20]) {
      const s = computeSchedule(T);
      expect(s.sigma[0]).toBe(0);
      expect(s.coef1[0]).toBeCloseTo(1, 9); // the last step returns x0̂
      for (let k = 1; k < T; k++) {
        expect(s.coef1[k]).toBeGreaterThan(0);
        expect(s.coef2[k]).toBeGreaterThan(0);
        expect(s.sigma[k]).toBeGreaterThan(s.sigma[k - 1]);
      }
    }
  });

  it('rejects step counts the model does not declare, naming them', () => {
    expect(() => scheduleFor({ supportedSteps: [1, 2, 4] }, 3, 'm')).toThrow(/models\.m: 3 steps not supported \(supportedSteps = \[1, 2, 4\]\)/);
  });

  it('matches every schedule the shipped manifest declares', (ctx) => {
    const p = path.join(MODELS_DIR, 'manifest.json');
    const manifest = fs.existsSync(p) ? JSON.parse(fs.readFileSync(p, 'utf8')) : null;
    type Entry = { supportedSteps: number[]; schedules?: Record<string, { time: number[]; coef1: number[]; coef2: number[]; sigma: number[] }> };
    const models = Object.entries((manifest?.models ?? {}) as Record<string, Entry>);
    if (!models.length) return ctx.skip('no models in public/models/manifest.json yet');
    for (const [name, entry] of models) {
      for (const [T, sched] of Object.entries(entry.schedules ?? {})) {
        const s = computeSchedule(Number(T));
        for (const key of ['time', 'coef1', 'coef2', 'sigma'] as const) {
          sched[key].forEach((v, k) => expect(Math.abs(s[key][k] - v), `${name} T=${T} ${key}[${k}]`).toBeLessThan(1e-7));
        }
        expect(scheduleFor(entry, Number(T), name).coef1[0]).toBe(sched.coef1[0]);
      }
    }
  });
});
