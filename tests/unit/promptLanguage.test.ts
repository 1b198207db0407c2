// The hint under a prompt with no English word (web/ui/controls.ts): the model only knows English captions.
import { describe, expect, it } from 'vitest';
import { promptLanguageNote } from '../../web/ui/controls';

describe('promptLanguageNote', () => {
  it('says so for a prompt without English words', () => {
    for (const p of ['一个人在跳舞', '🕺', 'человек прыгает', '  人が歩く 🕺 ', '1 2 3']) expect(promptLanguageNote(p)).toMatch(/English/);
  });
  it('is silent for English prompts (also mixed with other scripts) and for an empty prompt', () => {
    for (const p of ['a person walks', 'a person dances 🕺', 'walk 歩く', 'a', '', '   ']) expect(promptLanguageNote(p)).toBe(''); // 'a': the first key typed
  });
});
