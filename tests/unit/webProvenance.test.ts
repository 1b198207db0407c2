// What made the motion on screen (web/ui/provenance.ts): the joints JSON's generator block for one generation, a
// timeline, an edit and a live recording, and the page's link (a timeline stays in it across control changes; an edit
// or a recording, which a link cannot hold, is named in a note). Also the "Last generation" cells when nothing ran
// (web/ui/timings.ts).
import { describe, expect, it } from 'vitest';
import { generatorOf, linkOf, liveSource, seedOf, type Described } from '../../web/ui/provenance';
import { parseState, stateToSearch, type PageState, type StateLimits } from '../../web/ui/state';
import { decodeTimeline } from '../../web/ui/timeline-url';
import { timingCells } from '../../web/ui/timings';

const limits: StateLimits = {
  supportedSteps: [1, 2, 4, 10], defaultSteps: 10, defaultGuidance: 2.5, actions: ['walk', 'sit'], fps: 20, maxFrames: 196,
  defaultText: 'a person walks', compareSteps: [],
};

const controls: PageState = {
  mode: 'text', text: 'a person walks', action: 'walk', steps: 10, seconds: 6, guidance: 2.5, seed: 77, backend: 'auto', compare: false,
};

const segments = [
  { prompt: 'a person walks forward', seconds: 2, seed: 1 },
  { action: 'sit', seconds: 1.5, seed: 2 },
  { prompt: 'a person spins around', seconds: 3, seed: 3 },
];

/** A 3-segment timeline generated with 4 steps and guidance 3 (the controls said so then). */
const timeline: Described = {
  state: { ...controls, steps: 4, guidance: 3, seed: 1, seconds: 6.5 }, model: 'emdm-t2m-web', steps: 4,
  source: { kind: 'timeline', segments, models: ['emdm-t2m-web', 'emdm-a2m-web', 'emdm-t2m-web'], steps: 4, guidance: 3 },
};

const single: Described = { state: { ...controls, seed: 5 }, model: 'emdm-t2m-web', steps: 10 };

const inBetween = (base: Described): Described => ({
  state: { ...controls, text: 'a person spins around', seed: 99 }, model: 'emdm-t2m-web', steps: 10,
  source: { kind: 'edit', edit: { type: 'inbetween', keepFirstSeconds: 1, keepLastSeconds: 1.5 }, condition: { prompt: 'a person spins around' }, seed: 99, base },
});

describe('the joints JSON generator block', () => {
  it('one generation: the fields it always had, and kind', () => {
    expect(generatorOf(single)).toEqual({ kind: 'generate', model: 'emdm-t2m-web', mode: 'text', text: 'a person walks', action: undefined, steps: 10, guidance: 2.5, seed: 5 });
    const act = generatorOf({ ...single, state: { ...single.state, mode: 'action' } });
    expect(JSON.parse(JSON.stringify(act))).toEqual({ kind: 'generate', model: 'emdm-t2m-web', mode: 'action', action: 'walk', steps: 10, guidance: 2.5, seed: 5 });
  });

  it('a timeline: every segment (prompt or action, seconds, seed, model), the first standing for it, not the prompt box', () => {
    const g = generatorOf(timeline);
    expect(g).toMatchObject({ kind: 'timeline', model: 'emdm-t2m-web', mode: 'text', text: 'a person walks forward', steps: 4, guidance: 3, seed: 1 });
    expect(g.segments).toEqual([
      { prompt: 'a person walks forward', seconds: 2, seed: 1, model: 'emdm-t2m-web' },
      { action: 'sit', seconds: 1.5, seed: 2, model: 'emdm-a2m-web' },
      { prompt: 'a person spins around', seconds: 3, seed: 3, model: 'emdm-t2m-web' },
    ]);
    expect(g.text).not.toBe(controls.text);
  });

  it('an edit: its own prompt and seed, what it changed, and the block of the motion it edited', () => {
    const g = generatorOf(inBetween(timeline));
    expect(g).toMatchObject({ kind: 'edit', mode: 'text', text: 'a person spins around', seed: 99, edit: { type: 'inbetween', keepFirstSeconds: 1, keepLastSeconds: 1.5 } });
    expect(g.base).toEqual(generatorOf(timeline));
    // an edit of an edit keeps the chain
    const loop: Described = {
      state: { ...controls, mode: 'action', action: 'sit', seed: 7 }, model: 'emdm-a2m-web', steps: 2,
      source: { kind: 'edit', edit: { type: 'loop', inPlace: true }, condition: { action: 'sit' }, seed: 7, base: inBetween(single) },
    };
    const l = generatorOf(loop);
    expect(l).toMatchObject({ kind: 'edit', mode: 'action', action: 'sit', seed: 7, steps: 2, edit: { type: 'loop', inPlace: true } });
    expect((l.base as Record<string, unknown>).base).toEqual(generatorOf(single));
    expect(seedOf(loop)).toBe(7);
  });

  it('a live recording: its prompts with their times in it, the stream\'s seed (not the controls\')', () => {
    const log = [
      { text: 'a person walks', at: 0, latency: null },
      { text: 'a person waves', at: 50, latency: 0.61234 },
      { text: 'a person jumps', at: 95, latency: 0.4 },
      { text: 'a person sits down', at: 104, latency: null },
      { text: 'sent after the recording', at: 130, latency: null },
    ];
    // the last 60 s before 120 on the live clock: from 60
    const src = liveSource(log, 120, 60, { seed: 4242, steps: 4, guidance: 3 });
    expect(src.prompts).toEqual([
      { text: 'a person waves', at: -10, latency: 0.612 }, // playing as the recording starts
      { text: 'a person jumps', at: 35, latency: 0.4 },
      { text: 'a person sits down', at: 44 },
    ]);
    const g = generatorOf({ state: { ...controls, seed: 1, text: 'a person sits down' }, model: 'emdm-t2m-web', steps: 4, source: src });
    expect(g).toMatchObject({ kind: 'live', mode: 'text', text: 'a person sits down', seed: 4242, steps: 4, guidance: 3 });
    expect(g.prompts).toEqual(src.prompts);
  });
});

describe('the page link', () => {
  it('one generation: the controls\' state, no timeline, no note', () => {
    expect(linkOf(controls, null)).toEqual({ search: stateToSearch(controls), note: '' });
    expect(linkOf({ ...controls, seconds: 3 }, single)).toEqual({ search: stateToSearch({ ...controls, seconds: 3 }), note: '' });
  });

  it('a timeline stays in the link across control changes, with the steps and guidance it ran (it reproduces it)', () => {
    for (const changed of [controls, { ...controls, seconds: 3.5 }, { ...controls, text: 'something else' }, { ...controls, steps: 1, guidance: 5 }, { ...controls, mode: 'random' as const }]) {
      const { search, note } = linkOf(changed, timeline);
      expect(note).toBe('');
      const q = new URLSearchParams(search);
      expect(decodeTimeline(q.get('tl')!, limits.actions)).toEqual(segments);
      const parsed = parseState(search, limits, 0);
      expect(parsed.notices).toEqual([]);
      expect([parsed.state.steps, parsed.state.guidance]).toEqual([4, 3]);
      if (changed.seconds !== controls.seconds) expect(parsed.state.seconds).toBe(changed.seconds); // the controls are followed otherwise
    }
  });

  it('an edit keeps the link of the motion it edited and says the edit is not in it', () => {
    const onTimeline = linkOf({ ...controls, seconds: 2 }, inBetween(timeline));
    expect(onTimeline.search).toBe(linkOf({ ...controls, seconds: 2 }, timeline).search);
    expect(onTimeline.note).toMatch(/^The in-between on screen is not in this link.*opens the motion before the edit/);
    const onSingle = linkOf(controls, inBetween(single));
    expect(new URLSearchParams(onSingle.search).has('tl')).toBe(false);
    expect(onSingle.note).toMatch(/in-between/);
  });

  it('a live recording cannot be linked: the controls\' state and a note', () => {
    const rec: Described = { ...single, source: liveSource([], 60, 60, { seed: 1, steps: 4, guidance: 3 }) };
    expect(linkOf(controls, rec)).toEqual({ search: stateToSearch(controls), note: expect.stringMatching(/live recording on screen is not in this link/) });
    const loopOfRec: Described = { ...single, source: { kind: 'edit', edit: { type: 'loop', inPlace: false }, condition: { prompt: 'x' }, seed: 1, base: rec } };
    expect(linkOf(controls, loopOfRec).note).toMatch(/^The loop on screen is not in this link\. The live recording/);
  });
});

describe('Last generation cells', () => {
  const timings = { encodeMs: 0, stepMs: [], decodeMs: 0, totalMs: 41.2, backend: 'wasm' as const, threads: 0 };

  it('say that nothing was regenerated instead of zeros (an unchanged timeline shown again)', () => {
    const c = timingCells({ timings, modelCalls: 0 }, 0);
    expect(c).toEqual({ encode: '–', step: 'none: nothing was regenerated', decode: '–', total: '41 ms', backend: 'WASM', calls: '0' });
    expect(Object.values(c).join(' ')).not.toMatch(/0 threads|× 0|^0\.0 ms/);
  });

  it('show what ran', () => {
    const c = timingCells({ timings: { ...timings, encodeMs: 5, stepMs: [10, 20], decodeMs: 3, threads: 1 }, modelCalls: 2 }, 2);
    expect(c).toEqual({ encode: '5.0 ms', step: '15 ms × 2', decode: '5.0 ms', total: '43 ms', backend: 'WASM · 1 thread', calls: '2' });
  });

  it("count a timeline's steps begun together in its calls, and say so beside the timed ones", () => {
    const c = timingCells({ timings: { ...timings, stepMs: [10, 20], threads: 1 }, modelCalls: 4 }, 0);
    expect([c.step, c.calls]).toEqual(['15 ms × 2 (and 2 begun together)', '4']);
  });
});
