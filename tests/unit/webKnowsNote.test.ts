// The notice under an unknown prompt (web/ui/knows.ts) quotes the prompt: whole when short, cut at a word when long.
import { describe, expect, it } from 'vitest';
import { farNote, quoted } from '../../web/ui/knows';

describe('farNote', () => {
  it('quotes a short prompt whole, its spaces collapsed', () => {
    expect(quoted('  a person   does a cartwheel ')).toBe('“a person does a cartwheel”');
    expect(farNote('a person juggles')).toMatch(/^The model has not learned anything close to “a person juggles”, so/);
    expect(farNote('a person bows', 'bow')).toMatch(/^“a person bows” reads as bow, which this model does not do well yet/);
  });
  it('cuts a long prompt at a word, with an ellipsis, so the notice stays a few lines', () => {
    const long = 'a person slowly walks forward in a wide circle, then stops, turns around twice and sits down on a chair near the door';
    const q = quoted(long);
    expect(q.length).toBeLessThanOrEqual(64);
    expect(q).toBe('“a person slowly walks forward in a wide circle, then stops…”');
    expect(farNote(long)).toContain(q);
    expect(quoted('x'.repeat(200))).toBe(`“${'x'.repeat(60)}…”`); // no space to cut at: cut at the length
  });
});
