// Example prompts the shipped text model knows. The model's manifest entry may list them
// (`examples`: captions from its training set); otherwise they are the coverage benchmark's passing
// prompts (CHIPS) of the actions the dataset has, or, for a vocabulary without any, its labels as captions.
import type { Manifest } from '../../src/index';

const MAX_EXAMPLES = 6;

function isStringList(v: unknown): v is string[] {
  return Array.isArray(v) && v.every((x) => typeof x === 'string');
}

/**
 * [action, prompt]: prompts the shipped emdm-t2m-web made recognisably (the action classifier named the
 * action in ≥ 75 % of the motions; each of the first six in 8 of 8) at its default 10 steps and guidance:
 * `python -m emdm.eval.coverage --model emdm-t2m-web --chips` (docs/results/json/coverage-emdm-t2m-web.json).
 * tests/unit/webExamples.test.ts fails when a chip is not among them, or when its motions at the page's settings do
 * not move (the realism benchmark's `moving`: "a person punches" was recognised 8 of 8 from a boxer's guard that never
 * throws a fist). Kick, dance, jump and the waves are not: the model does not make them reliably at 10 steps
 * (docs/RESULTS.md, "Coverage per action").
 */
const CHIPS: [string, string][] = [
  ['walk', 'a person walks'],
  ['run', 'a person runs'],
  ['bow', 'a person bows'],
  ['throw', 'a person throws a ball'],
  ['squat', 'a person squats down'],
  ['raise-both-hands', 'a person raises both hands'],
  ['lie-down', 'a person lies down'],
  ['walk-backward', 'a person walks backward'],
  ['climb', 'a person climbs'],
];

/** Third person singular of an English verb ('walk' → 'walks', 'punch' → 'punches'). */
function thirdPerson(verb: string): string {
  if (/(s|sh|ch|x|z)$/.test(verb)) return `${verb}es`;
  if (/[^aeiou]y$/.test(verb)) return `${verb.slice(0, -1)}ies`;
  return `${verb}s`;
}

/** An action label as a caption: 'wave-right-hand' → 'a person waves the right hand'. */
export function labelToPrompt(label: string): string {
  const words = label.replace(/([a-z])([A-Z])/g, '$1 $2').toLowerCase().split(/[\s_-]+/).filter(Boolean);
  if (!words.length) return '';
  const [verb, ...rest] = words;
  const tail = rest.join(' ').replace(/\b(left|right) (hand|arm|leg|foot)\b/g, 'the $1 $2');
  return `a person ${thirdPerson(verb)}${tail ? ` ${tail}` : ''}`;
}

export function examplePrompts(m: Manifest, textModel: string | null, actions: string[]): string[] {
  const entry = textModel ? m.models[textModel] : undefined;
  const listed = entry?.examples;
  if (isStringList(listed) && listed.length) return listed.map((s) => s.trim()).filter(Boolean).slice(0, MAX_EXAMPLES);
  const chips = CHIPS.filter(([a]) => actions.includes(a)).map(([, prompt]) => prompt);
  if (chips.length) return chips.slice(0, MAX_EXAMPLES);
  return actions.slice(0, MAX_EXAMPLES).map(labelToPrompt).filter(Boolean);
}
