// The notice under an unknown prompt (web/ui/knows.ts) quotes the prompt: whole when short, cut at a word when long.
import { describe, expect, it } from 'vitest';
import { farNote, quoted } from '../../web/ui/knows';

describe('farNote', () => {
  it('quotes a short prompt whole, its spaces collapsed', () => {
    expect(quoted('  a person   does a cartwheel ')).toBe('“a person does a cartwheel”');
    expect(farNote('a person juggles')).toMatch(/^The model has not learned anything close to “a person juggles”, so/);
    expect(farNote('a person bows', 'bow')).toMatch(/^“a person bows” reads as bow, which this model does not do well yet/);
  });
  it('says a prompt in another language is not English before anything else (the model reads English only)', () => {
    const fr = farNote('une personne marche en avant', 'dance');
    expect(fr).toMatch(/^“une personne marche en avant” does not read as English, and the model understands English prompts only, so/);
    expect(fr).toMatch(/These English prompts are the closest it does well:$/);
    expect(fr).not.toContain('dance');
    expect(farNote('a person juggles')).not.toContain('English');
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
