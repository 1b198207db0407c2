// The timeline in the page URL (web/ui/timeline-url.ts): what a shared link restores, and what it refuses.
import { describe, expect, it } from 'vitest';
import { MAX_SEGMENTS, MAX_TIMELINE_CHARS, TimelineUrlError, decodeTimeline, encodeTimeline, withRawTimeline, withTimeline } from '../../web/ui/timeline-url';

const actions = ['sit', 'walk'];

describe('timeline URL', () => {
  it('round-trips prompts, actions, seconds and seeds through the query string', () => {
    const segs = [{ prompt: 'a person walks & waves?', seconds: 10, seed: 4294967295 }, { action: 'sit', seconds: 2.5, seed: 0 }];
    const search = withTimeline('?mode=text&text=x', segs);
    const q = new URLSearchParams(search);
    expect(q.get('mode')).toBe('text');
    expect(decodeTimeline(q.get('tl')!, actions)).toEqual(segs);
    expect(encodeTimeline(segs)).toBe('[["a person walks & waves?",10,4294967295],[{"a":"sit"},2.5,0]]');
    expect(withTimeline(search, null)).toBe('?mode=text&text=x');
  });

  it('keeps a long prompt whole (a reload makes the timeline that was shared, not a cut one)', () => {
    const long = `a person walks forward ${'and keeps walking '.repeat(170)}`.trim();
    expect(long.length).toBeGreaterThan(3000);
    const segs = [{ prompt: long, seconds: 4, seed: 7 }, { prompt: 'a person sits down', seconds: 3, seed: 8 }];
    expect(decodeTimeline(new URLSearchParams(withTimeline('', segs)).get('tl')!, actions)).toEqual(segs);
  });

  it('keeps a value it could not read as it was (the page leaves it in the address)', () => {
    const search = withRawTimeline('?mode=text&text=a+person+waves', '[["a person walks", 1e308, 2]');
    const q = new URLSearchParams(search);
    expect(q.get('text')).toBe('a person waves');
    expect(q.get('tl')).toBe('[["a person walks", 1e308, 2]');
    expect(() => decodeTimeline(q.get('tl')!, actions)).toThrow(/not JSON/);
  });

  it('keeps bad lengths and empty prompts for planTimeline to name, refuses a broken shape', () => {
    expect(decodeTimeline('[["",0,1]]', actions)).toEqual([{ prompt: '', seconds: 0, seed: 1 }]);
    for (const [v, msg] of [
      ['[[', /not JSON/], ['{}', /a list of \[prompt, seconds, seed\]/], ['[["a",1]]', /segment 1 must be \[prompt, seconds, seed\]/],
      ['[["a","x",1]]', /segment 1: seconds must be a number/], ['[["a",1,-1]]', /seed must be an integer/],
      ['[["a",1,1],[{"a":"fly"},1,1]]', /segment 2: expected a prompt or \{"a": action\} with an action of sit, walk/],
    ] as const) {
      expect(() => decodeTimeline(v, actions)).toThrow(TimelineUrlError);
      expect(() => decodeTimeline(v, actions)).toThrow(msg);
    }
  });

  it('refuses a deeply nested, an over-long or a 201-segment link with its own error, not a stack overflow', () => {
    const deep = `[${'['.repeat(250_000)}${']'.repeat(250_000)}]`;
    const many = JSON.stringify(Array.from({ length: MAX_SEGMENTS + 1 }, (_, i) => ['walk', 0.1, i]));
    for (const [v, msg] of [
      [deep, /characters; at most/], [`[${'['.repeat(50_000)}"a",1,1${']'.repeat(50_000)}]`, /segment 1 must be \[prompt, seconds, seed\], got a list of 1 entry/],
      [`[[${'['.repeat(50_000)}${']'.repeat(50_000)},1,1]]`, /segment 1: expected a prompt or \{"a": action\}.*got a list of 1 entry/],
      [many, /201 segments; at most 200/], [`[["${'x'.repeat(MAX_TIMELINE_CHARS)}",1,1]]`, /characters; at most/],
    ] as const) {
      expect(() => decodeTimeline(v, actions)).toThrow(TimelineUrlError);
      expect(() => decodeTimeline(v, actions)).toThrow(msg);
    }
  });
});
