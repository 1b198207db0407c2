/**
 * The sampler registry: `SamplingSettings.method` → its update rule (src/sampler/update.ts). A new sampler is one
 * new file exporting its SamplerRule and one `registerSampler` line here; the loop (src/sampler/sampler.ts), the
 * generator and the worker need no change.
 */
import { ddgan } from './ddgan';
import { ddim } from './ddim';
import type { SamplerRule } from './update';

const rules = new Map<string, SamplerRule>();

/** Add a rule under its name (a name already taken is refused: two rules cannot share one). */
export function registerSampler(rule: SamplerRule): void {
  if (rules.has(rule.name)) throw new Error(`registerSampler: a sampler named '${rule.name}' is already registered`);
  rules.set(rule.name, rule);
}

/** The rule `method` names; an unknown name fails saying which exist. */
export function samplerRule(method: string): SamplerRule {
  const rule = rules.get(method);
  if (!rule) throw new Error(`sampler: method '${method}' is not a registered sampler (registered: ${[...rules.keys()].join(', ')})`);
  return rule;
}

registerSampler(ddgan);
registerSampler(ddim);
