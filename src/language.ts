/**
 * Whether a prompt reads as English: the shipped text encoder (all-MiniLM-L6-v2) and the training captions are English,
 * so a prompt in another language lands far from everything the model learned, and the unknown-prompt notice should say
 * why. A heuristic on words, not a language detector: a prompt is *not English* when it has letters but none in the
 * Latin alphabet (Cyrillic, Greek, CJK…), or more words of the short list of other languages' common prompt words than
 * of English's, or accented letters and no English word at all. Gibberish ("asdf qwerty") and English with a foreign
 * word ("a person dances the samba") read as English. Python says the same (emdm.prompt_language; the word lists are
 * checked equal by tests/python/test_prompt_language.py).
 */

/** English words common in motion prompts (function words, people, body parts, common motion verbs). */
export const ENGLISH_WORDS: readonly string[] = [
  'a', 'an', 'the', 'and', 'or', 'then', 'while', 'with', 'without', 'to', 'of', 'in', 'on', 'at', 'up', 'down', 'into',
  'over', 'around', 'from', 'forward', 'forwards', 'backward', 'backwards', 'left', 'right', 'both', 'his', 'her', 'their',
  'its', 'he', 'she', 'they', 'it', 'is', 'are', 'was', 'does', 'person', 'someone', 'somebody', 'man', 'woman', 'people',
  'figure', 'character', 'guy', 'girl', 'boy', 'hand', 'hands', 'arm', 'arms', 'leg', 'legs', 'foot', 'feet', 'head',
  'body', 'knee', 'knees', 'walks', 'walk', 'walking', 'runs', 'run', 'running', 'jumps', 'jump', 'jumping', 'waves',
  'wave', 'waving', 'dances', 'dance', 'dancing', 'kicks', 'kick', 'punches', 'punch', 'bows', 'bow', 'sits', 'sit',
  'stands', 'stand', 'turns', 'turn', 'raises', 'raise', 'lifts', 'lift', 'throws', 'throw', 'climbs', 'climb', 'squats',
  'squat', 'slowly', 'quickly', 'happily', 'again', 'steps', 'step', 'moves', 'move',
];

/** Common words of prompts in French, Spanish, German, Italian, Portuguese and Dutch that are not English words. */
export const OTHER_WORDS: readonly string[] = [
  'une', 'un', 'le', 'la', 'les', 'des', 'du', 'personne', 'homme', 'femme', 'qui', 'avec', 'et', 'il', 'elle', 'marche',
  'court', 'saute', 'danse', 'bras', 'main', 'mains', 'jambe', 'lève', 'leve', 'salue', 'una', 'uno', 'el', 'los', 'las',
  'persona', 'hombre', 'mujer', 'con', 'y', 'camina', 'corre', 'salta', 'baila', 'brazos', 'manos', 'levanta', 'saluda',
  'ein', 'eine', 'einer', 'der', 'das', 'und', 'mit', 'mann', 'frau', 'mensch', 'läuft', 'lauft', 'springt', 'tanzt',
  'geht', 'hebt', 'winkt', 'hände', 'hande', 'arme', 'lo', 'gli', 'uomo', 'donna', 'che', 'cammina', 'balla',
  'alza', 'uma', 'um', 'pessoa', 'homem', 'mulher', 'com', 'anda', 'pula', 'dança', 'danca', 'een', 'persoon', 'loopt',
  'rent', 'danst', 'zwaait', 'met', 'de', 'het', 'en',
];

const english = new Set(ENGLISH_WORDS);
const other = new Set(OTHER_WORDS);

/** Whether `prompt` reads as English (see the header); true for a prompt without letters. */
export function readsAsEnglish(prompt: string): boolean {
  const words = prompt.normalize('NFC').toLowerCase().match(/\p{L}+/gu) ?? [];
  if (words.length === 0) return true;
  if (!words.some((w) => /[a-z\u00c0-\u024f]/.test(w))) return false; // letters, none Latin
  const en = words.filter((w) => english.has(w)).length;
  const xx = words.filter((w) => other.has(w)).length;
  if (xx > en) return false;
  return en > 0 || !words.some((w) => /[^a-z]/.test(w)); // accented letters and no English word
}
