// Example prompts the shipped text model knows. The model's manifest entry may list them
// (`examples`: captions from its training set); otherwise they are built from the dataset's action
// vocabulary (the labels of the action model), which the captions of the training set describe.
import type { Manifest } from '../../src/manifest';

const MAX_EXAMPLES = 6;

function isStringList(v: unknown): v is string[] {
  return Array.isArray(v) && v.every((x) => typeof x === 'string');
}

/** 'walk-turn-left' → 'a person walk turn left'. */
export function labelToPrompt(label: string): string {
  return `a person ${label.replace(/[_-]+/g, ' ').replace(/([a-z])([A-Z])/g, '$1 $2').toLowerCase().trim()}`;
}

export function examplePrompts(m: Manifest, textModel: string | null, actions: string[]): string[] {
  const entry = textModel ? m.models[textModel] : undefined;
  const listed = entry?.examples;
  if (isStringList(listed) && listed.length) return listed.map((s) => s.trim()).filter(Boolean).slice(0, MAX_EXAMPLES);
  return actions.slice(0, MAX_EXAMPLES).map(labelToPrompt);
}
