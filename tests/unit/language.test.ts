// The unknown-prompt notice says when a prompt is not English (src/language.ts): the model reads English only.
import { describe, expect, it } from 'vitest';
import { ENGLISH_WORDS, OTHER_WORDS, readsAsEnglish } from '../../src/language';

describe('readsAsEnglish', () => {
  it('says a prompt in another language is not English', () => {
    for (const p of ['une personne marche en avant', 'Une personne lève les deux mains', 'una persona camina', 'der Mann springt hoch',
      'eine Person winkt mit beiden Händen', 'uma pessoa anda', 'a pessoa dança', 'een persoon loopt', 'un uomo cammina',
      '人が歩いている', 'человек идёт', 'άνθρωπος περπατά', 'Salut ça va', 'Une personne le\u0300ve les mains'])
      expect(readsAsEnglish(p), p).toBe(false);
  });
  it('reads English (with a foreign word or two), gibberish and prompts without letters as English', () => {
    for (const p of ['a person walks', 'A person waves with both hands happily', 'a person dances the samba',
      'someone does the macarena', 'a person waves to la la land', 'asdf qwerty', '123', '', 'a man kicks, then bows'])
      expect(readsAsEnglish(p), p).toBe(true);
  });
  it('keeps its two word lists apart', () => {
    expect(OTHER_WORDS.filter((w) => ENGLISH_WORDS.includes(w))).toEqual([]);
    expect(new Set(OTHER_WORDS).size).toBe(OTHER_WORDS.length);
    expect(new Set(ENGLISH_WORDS).size).toBe(ENGLISH_WORDS.length);
  });
});
