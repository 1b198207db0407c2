// The bone map editor of the character picker (web/ui/character-picker.ts): one list per joint of ours,
// offering the character's bones, for the joints the automatic map missed; the maps a visitor applied are
// kept per file name in localStorage and can be exported as JSON.
import { type BoneInfo, type BoneMapping, JOINT_NAMES, type JointName, mappingFromJSON, mappingToJSON } from '../../src/index';

const STORE = 'emdm.boneMap.';

/** The most bones each of the editor's 22 lists offers (22 × 100 000 options froze the page for a minute). */
export const MAX_EDITOR_BONES = 300;

/** The bone names the editor offers: the mapped ones first, then the file's order, at most MAX_EDITOR_BONES. */
export function editorChoices(bones: readonly BoneInfo[], mapping: BoneMapping): string[] {
  const names = new Set(Object.values(mapping).filter((n): n is string => typeof n === 'string' && bones.some((b) => b.name === n)));
  for (const b of bones) {
    if (names.size >= MAX_EDITOR_BONES) break;
    names.add(b.name);
  }
  return [...names];
}

/** The map a visitor applied to the file `name` before, if any (a broken entry reads as none). */
export function savedMap(name: string): BoneMapping | undefined {
  try {
    const s = localStorage.getItem(STORE + name);
    return s ? mappingFromJSON(s) : undefined;
  } catch {
    return undefined;
  }
}

/** Keep `m` as the map of the file `name`. */
export function saveMap(name: string, m: BoneMapping): void {
  localStorage.setItem(STORE + name, mappingToJSON(m));
}

export class BoneMapEditor {
  /** the bones the editor offers (of the last file read, shown or refused) */
  bones: BoneInfo[] = [];

  /** `editor`: the <details> that holds it; `rows`: where the lists go */
  constructor(readonly editor: HTMLDetailsElement, private readonly rows: HTMLElement) {}

  show(bones: BoneInfo[], mapping: BoneMapping): void {
    this.rows.replaceChildren();
    this.bones = bones;
    const names = editorChoices(bones, mapping);
    if (names.length < bones.length) {
      this.rows.append(Object.assign(document.createElement('p'), {
        className: 'hint', textContent: `The lists offer ${names.length} of its ${bones.length} bones (the mapped ones, then the first in the file).`,
      }));
    }
    for (const j of JOINT_NAMES) {
      const row = document.createElement('label');
      row.className = mapping[j] ? 'char-map-row' : 'char-map-row unmapped';
      const sel = document.createElement('select');
      sel.dataset.joint = j;
      sel.append(new Option('(none)', ''));
      for (const n of names) sel.append(new Option(n, n, false, mapping[j] === n));
      row.append(document.createTextNode(j), sel);
      this.rows.append(row);
    }
    this.editor.hidden = false;
    if (JOINT_NAMES.some((j) => !mapping[j])) this.editor.open = true;
  }

  /** The map as the lists set it. */
  edited(): BoneMapping {
    const m: BoneMapping = {};
    this.rows.querySelectorAll('select').forEach((sel) => {
      if (sel.value) m[sel.dataset.joint as JointName] = sel.value;
    });
    return m;
  }
}
