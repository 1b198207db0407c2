// Example prompts the shipped text model knows. The model's manifest entry may list them
// (`examples`: captions from its training set); otherwise they are built from the dataset's action
// vocabulary (the labels of the action model), which the captions of the training set describe.
import type { Manifest } from '../../src/manifest';

const MAX_EXAMPLES = 6;

function isStringList(v: unknown): v is string[] {
  return Array.isArray(v) && v.every((x) => typeof x === 'string');
}

/** Actions that make good first examples, in this order when the model knows them. */
const PREFERRED = ['walk', 'run', 'wave-right-hand', 'kick', 'dance', 'bow', 'squat', 'raise-both-hands', 'punch', 'jump'];

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

function orderedLabels(actions: string[]): string[] {
  const first = PREFERRED.filter((a) => actions.includes(a));
  return [...first, ...actions.filter((a) => !first.includes(a))];
}

export function examplePrompts(m: Manifest, textModel: string | null, actions: string[]): string[] {
  const entry = textModel ? m.models[textModel] : undefined;
  const listed = entry?.examples;
  if (isStringList(listed) && listed.length) return listed.map((s) => s.trim()).filter(Boolean).slice(0, MAX_EXAMPLES);
  return orderedLabels(actions).slice(0, MAX_EXAMPLES).map(labelToPrompt).filter(Boolean);
}
