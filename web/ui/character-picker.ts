// "Your character": drop (or pick) a .glb/.gltf/.vrm and it replaces the built-in character on the
// stage, performing the motion on screen (src/character/retarget: load → bone map → retarget); one
// click brings the built-in character back. Joints the automatic map missed can be picked in a small
// editor; the map is kept per file name in localStorage and can be exported as JSON. Downloads: the
// character with the clip as GLB, and the clip as BVH on its bone names.
// Retargeting runs in slices (retargetMotionAsync: ~8 ms of work, then the page draws), so a 60 s motion
// does not freeze the page; a newer motion cancels the one being put on the character (newest wins), and
// the character plays its previous clip until the new one is ready.
import { AnimationMixer, Group, LoopOnce, type AnimationAction, type Object3D } from 'three';
import { clone as cloneSkinned } from 'three/addons/utils/SkeletonUtils.js';
import { type CharacterFile, CharacterLoadError, type LoadedCharacter, loadCharacter, type BoneInfo, type BoneMapping, MappingError, mappingFromJSON, mappingToJSON, validateMapping, type RetargetResult, retargetMotionAsync, type BvhUnits, bvhFileName, characterToBVH, characterToGLB, type Motion, JOINT_NAMES, type JointName, type Skeleton } from '../../src/index';
import { contactsFromFeatures, plantContacts } from '../../src/motion/footContact';
import { saveBlob } from './dom';

export interface PickerHost {
  /** adds an object to the stage's scene */
  add(o: Object3D): void;
  /** the built-in character (hidden while the user's is shown) */
  builtIn: Object3D;
  skeleton: Skeleton;
  /** the playback clock, seconds */
  time(): number;
  notify(kind: 'info' | 'warn' | 'error', text: string): void;
  /** the panel section the picker's controls go before */
  before: HTMLElement;
  /** the character on the stage changed (the visitor's shown or gone): the compare view re-asks compare() */
  changed?(): void;
}

/** One copy of the visitor's character performing one motion. */
interface Performer {
  root: Object3D;
  holder: Group;
  mixer: AnimationMixer | null;
  action: AnimationAction | null;
  result: RetargetResult | null;
  /** the retargeting under way (aborted when a newer motion arrives), null when none */
  job: AbortController | null;
}

const STORE = 'emdm.boneMap.';
const ACCEPT = '.glb,.gltf,.vrm,.bin,.png,.jpg,.jpeg,.webp,.ktx2';

interface Shown extends Performer {
  ch: LoadedCharacter;
  /** the compare view's second copy (the DDIM motion), made when a comparison is shown */
  twin: Performer | null;
  /** what the status line says about it once its motion is on it */
  summary: string;
}

/** Retargeting runs of this page visit (window.emdmCharacter.retargets). */
export interface RetargetStats {
  started: number;
  finished: number;
  /** stopped because a newer motion (or another character) came first */
  cancelled: number;
  /** the last one that finished: frames, wall time on the page and the slices it was cut into, performance.now() at start/end */
  last: { frames: number; ms: number; slices: number; start: number; end: number; firstSliceMs: number; longestSliceMs: number } | null;
}

/** What the page's tests read (window.emdmCharacter). */
export interface CharacterProbe {
  active: boolean;
  builtInVisible: boolean;
  name: string;
  mapped: number;
  status: string;
  /** the compare view's second copy is performing the DDIM motion */
  comparing: boolean;
  /** a motion is being put on the visitor's character (active/comparing are false meanwhile) */
  retargeting: boolean;
  /** frames of the clip the (main) copy plays, 0 without one */
  frames: number;
  retargets: RetargetStats;
  /** world position of the bone playing `joint` (of the compare view's second copy: `copy` 'compare'), or null */
  jointWorld(joint: JointName, copy?: 'main' | 'compare'): [number, number, number] | null;
}

export class CharacterPicker {
  private shown: Shown | null = null;
  private motion: Motion | null = null;
  /** the compare view's second motion (DDIM), null when not comparing */
  private compareMotion: Motion | null = null;
  private stem = 'emdm';
  private files: CharacterFile[] = [];
  /** the bones the editor offers (of the last file read, shown or refused) */
  private editorBones: BoneInfo[] = [];
  private readonly el: HTMLElement;
  private readonly status: HTMLElement;
  private readonly back: HTMLButtonElement;
  private readonly editor: HTMLDetailsElement;
  private readonly rows: HTMLElement;
  private readonly dlGlb: HTMLButtonElement;
  private readonly dlBvh: HTMLButtonElement;
  private readonly stats: RetargetStats = { started: 0, finished: 0, cancelled: 0, last: null };
  /** files read so far (a newer one wins over one still loading) */
  private loads = 0;
  /** a character being readied off the stage (the motion being put on it), null when none */
  private pending: Shown | null = null;

  constructor(private readonly host: PickerHost) {
    const el = document.createElement('section');
    el.className = 'character-picker';
    el.id = 'character-picker';
    el.innerHTML = `
      <h2>Character</h2>
      <div class="download-row">
        <button type="button" id="char-open" class="ghost" title="A rigged humanoid: .glb, .vrm, or .gltf with its files (or drop them on the page)">Your character…</button>
        <input type="file" id="char-file" accept="${ACCEPT}" multiple hidden>
        <button type="button" id="char-builtin" class="ghost" hidden>Built-in</button>
      </div>
      <p id="char-status" class="hint" role="status"></p>
      <details id="char-map" hidden>
        <summary>Bone map</summary>
        <div id="char-map-rows" class="char-map-rows"></div>
        <div class="download-row">
          <button type="button" id="char-map-apply" class="ghost">Apply</button>
          <button type="button" id="char-map-export" class="ghost">Export JSON</button>
        </div>
      </details>
      <div class="download-row">
        <button type="button" id="dl-char-glb" class="ghost" disabled title="Your character with the motion (binary glTF)">GLB on it</button>
        <button type="button" id="dl-char-bvh" class="ghost" disabled title="The motion on your character's bone names (BVH, in the unit chosen under Download)">BVH on it</button>
      </div>`;
    host.before.parentElement!.insertBefore(el, host.before);
    this.el = el;
    const q = <T extends HTMLElement>(id: string) => el.querySelector<T>(`#${id}`)!;
    this.status = q('char-status');
    this.back = q<HTMLButtonElement>('char-builtin');
    this.editor = q<HTMLDetailsElement>('char-map');
    this.rows = q('char-map-rows');
    this.dlGlb = q<HTMLButtonElement>('dl-char-glb');
    this.dlBvh = q<HTMLButtonElement>('dl-char-bvh');
    const input = q<HTMLInputElement>('char-file');
    q('char-open').addEventListener('click', () => input.click());
    input.addEventListener('change', () => {
      if (input.files?.length) void this.open(Array.from(input.files));
      input.value = '';
    });
    this.back.addEventListener('click', () => this.useBuiltIn());
    q('char-map-apply').addEventListener('click', () => void this.applyEditor());
    q('char-map-export').addEventListener('click', () => this.exportMap());
    this.dlGlb.addEventListener('click', () => this.download('glb'));
    this.dlBvh.addEventListener('click', () => this.download('bvh'));
    // drop anywhere on the page
    document.addEventListener('dragover', (e) => {
      if (e.dataTransfer?.types.includes('Files')) e.preventDefault();
    });
    document.addEventListener('drop', (e) => {
      const files = e.dataTransfer?.files;
      if (!files?.length) return;
      e.preventDefault();
      void this.open(Array.from(files));
    });
    const tick = () => {
      this.update();
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
    (window as unknown as { emdmCharacter: CharacterProbe }).emdmCharacter = this.probe();
  }

  /** The motion on screen changed: put it on the user's character (if one is shown). */
  setMotion(motion: Motion, stem: string): void {
    this.motion = motion;
    this.stem = stem;
    if (this.shown) this.retarget().catch((e) => this.fail(e));
  }

  /**
   * The compare view: `motion` (the DDIM one, same clock as the main motion) on a second copy of the
   * visitor's character, or null to leave the comparison. Returns the two objects for the split view
   * (left: the main motion, right: this one), or null when the built-in characters are on the stage.
   */
  compare(motion: Motion | null): { left: Object3D; right: Object3D } | null {
    this.compareMotion = motion;
    const s = this.shown;
    if (!s) return null;
    if (!motion) {
      if (s.twin) this.drop(s.twin);
      s.twin = null;
      return null;
    }
    // the original at rest (its clip poses it again on the next frame) for the copy's rest pose
    s.ch.restPose();
    if (!s.twin) {
      // a copy of the character (skins re-bound to the copy's bones), its nodes named as the original's
      const root = cloneSkinned(s.ch.root);
      const holder = new Group();
      holder.name = 'user-character-compare';
      holder.add(root);
      this.host.add(holder);
      s.twin = { root, holder, mixer: null, action: null, result: null, job: null };
    }
    const twin = s.twin;
    this.perform(twin, motion, s.ch).catch((e) => {
      if (this.shown?.twin === twin) this.fail(e);
    });
    return { left: s.holder, right: s.twin.holder };
  }

  /** The visitor's character is on the stage (the built-in one hidden). */
  get active(): boolean {
    return !!this.shown;
  }

  private say(text: string): void {
    this.status.textContent = text;
  }

  private savedMap(name: string): BoneMapping | undefined {
    try {
      const s = localStorage.getItem(STORE + name);
      return s ? mappingFromJSON(s) : undefined;
    } catch {
      return undefined;
    }
  }

  async open(list: File[]): Promise<void> {
    this.say(`Reading ${list.map((f) => f.name).join(', ')}…`);
    try {
      this.files = await Promise.all(list.map(async (f) => ({ name: f.name, data: await f.arrayBuffer() })));
      await this.load(this.savedMap(this.mainName()));
    } catch (e) {
      this.fail(e);
    }
  }

  private mainName(): string {
    return this.files.find((f) => /\.(glb|gltf|vrm)$/i.test(f.name))?.name ?? '';
  }

  /**
   * Read the files given and, once the new character is loaded, mapped and performing the motion on screen, put it
   * on the stage in place of the current one; a file that fails at any point leaves the current character as it was.
   */
  private async load(mapping?: BoneMapping): Promise<void> {
    const token = ++this.loads;
    this.pending?.job?.abort(); // a character still being readied gives way to this one
    let ch: LoadedCharacter;
    try {
      ch = await loadCharacter(this.files, { mapping });
    } catch (e) {
      if (e instanceof CharacterLoadError && e.reason === 'not-humanoid' && e.bones && !mapping && token === this.loads) {
        // offer the editor with what was recognised
        this.showEditor(e.bones, e.mapping ?? {});
      }
      throw e;
    }
    if (token !== this.loads) return; // another file came meanwhile
    const holder = new Group();
    holder.name = 'user-character';
    holder.add(ch.root);
    const summary = `${ch.name}: ${22 - ch.unmapped.length}/22 joints mapped (${ch.mappingSource === 'vrm' ? `VRM ${ch.vrm} humanoid` : ch.mappingSource === 'user' ? 'your map' : 'by bone names'}), read in ${Math.round(ch.loadMs)} ms`;
    const next: Shown = { ch, root: ch.root, holder, mixer: null, action: null, result: null, job: null, twin: null, summary };
    const motion = this.motion;
    if (motion) {
      // off the stage until the motion is on it: the current character keeps playing meanwhile
      this.say(`Putting the motion on ${ch.name}…`);
      this.pending = next;
      try {
        if (!(await this.perform(next, motion, ch, (f) => this.say(`Putting the motion on ${ch.name}… ${Math.round(f * 100)}%`)))) return;
      } finally {
        if (this.pending === next) this.pending = null;
      }
      if (token !== this.loads) return;
    }
    this.useBuiltIn(false);
    this.host.add(holder);
    this.shown = next;
    this.host.builtIn.visible = false;
    this.back.hidden = false;
    this.showEditor(ch.boneInfos, ch.mapping);
    this.say(summary);
    this.dlGlb.disabled = !next.result;
    this.dlBvh.disabled = !next.result;
    if (this.motion !== motion) this.retarget().catch((e) => this.fail(e)); // a newer motion came meanwhile
    if (this.compareMotion) this.compare(this.compareMotion);
    this.host.changed?.();
  }

  /** Put the motion on screen on the visitor's character (the previous clip plays until it is ready). */
  private async retarget(): Promise<void> {
    const s = this.shown;
    if (!s || !this.motion) return;
    s.ch.restPose();
    this.dlGlb.disabled = true;
    this.dlBvh.disabled = true;
    const name = s.ch.name;
    const done = await this.perform(s, this.motion, s.ch, (f) => this.say(`Putting the motion on ${name}… ${Math.round(f * 100)}%`));
    if (!done || this.shown !== s) return;
    this.dlGlb.disabled = false;
    this.dlBvh.disabled = false;
    this.say(s.summary);
  }

  /**
   * Retarget `m` onto one copy of the character (at rest as loaded; read before the first slice ends) in
   * slices, then play it on the page's clock. A newer call for the same copy cancels this one: false then.
   */
  private async perform(p: Performer, m: Motion, ch: LoadedCharacter, progress?: (fraction: number) => void): Promise<boolean> {
    p.job?.abort();
    const job = new AbortController();
    p.job = job;
    if (p.root !== ch.root) restLike(p.root, ch.root);
    // the runs our clean-up pinned (m.joints are the shown, cleaned joints): the character holds the same frames still
    const contacts = m.features.length === m.frames * 263 ? plantContacts(m.joints, m.frames, contactsFromFeatures(m.features, m.frames), this.host.skeleton) : null;
    const stats = this.stats;
    stats.started++;
    const start = performance.now();
    let slices = 1;
    let res: RetargetResult;
    let firstSliceMs = NaN;
    let longestSliceMs = 0;
    try {
      const running = retargetMotionAsync(p.root, ch.mapping, { joints: m.joints, frames: m.frames, fps: m.fps, contacts }, this.host.skeleton, {
        signal: job.signal,
        onProgress: (f, ms) => {
          slices++;
          longestSliceMs = Math.max(longestSliceMs, ms);
          progress?.(f);
        },
      });
      // the first slice (the rest pose read, our IK solved for every frame) ran before retargetMotionAsync returned
      firstSliceMs = performance.now() - start;
      res = await running;
    } catch (e) {
      if (job.signal.aborted) {
        stats.cancelled++;
        return false;
      }
      if (p.job === job) p.job = null;
      throw e;
    }
    p.job = null;
    stats.finished++;
    const end = performance.now();
    stats.last = { frames: m.frames, ms: end - start, slices, start, end, firstSliceMs, longestSliceMs };
    p.mixer?.stopAllAction();
    p.mixer?.uncacheRoot(p.root);
    // shown at our size and facing, so the camera that follows our pelvis follows it too
    p.holder.scale.setScalar(1 / res.scale);
    p.holder.rotation.y = -res.yaw;
    p.mixer = new AnimationMixer(p.root);
    p.action = p.mixer.clipAction(res.clip);
    p.action.setLoop(LoopOnce, 1);
    p.action.clampWhenFinished = true;
    p.action.play();
    p.result = res;
    return true;
  }

  private drop(p: Performer): void {
    p.job?.abort();
    p.mixer?.stopAllAction();
    p.holder.removeFromParent();
  }

  private update(): void {
    const s = this.shown;
    for (const p of [s, s?.twin]) {
      if (!p?.mixer || !p.action || !p.result) continue;
      p.action.time = Math.min(Math.max(this.host.time(), 0), p.result.clip.duration);
      p.mixer.update(0);
    }
  }

  useBuiltIn(say = true): void {
    if (say) {
      this.loads++; // the visitor's choice: a character still loading does not replace it
      this.pending?.job?.abort();
    }
    const s = this.shown;
    if (s) {
      this.drop(s);
      if (s.twin) this.drop(s.twin);
      this.shown = null;
    }
    this.host.builtIn.visible = true;
    this.back.hidden = true;
    this.dlGlb.disabled = true;
    this.dlBvh.disabled = true;
    if (say) {
      this.editor.hidden = true;
      this.say('');
      if (s) this.host.changed?.();
    }
  }

  private showEditor(bones: BoneInfo[], mapping: BoneMapping): void {
    this.rows.replaceChildren();
    this.editorBones = bones;
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

  private editedMap(): BoneMapping {
    const m: BoneMapping = {};
    this.rows.querySelectorAll('select').forEach((sel) => {
      if (sel.value) m[sel.dataset.joint as JointName] = sel.value;
    });
    return m;
  }

  private async applyEditor(): Promise<void> {
    const m = this.editedMap();
    try {
      validateMapping(m, this.editorBones);
      await this.load(m);
      localStorage.setItem(STORE + this.mainName(), mappingToJSON(m));
    } catch (e) {
      this.fail(e);
    }
  }

  private exportMap(): void {
    const m = this.editedMap();
    saveBlob(new Blob([mappingToJSON(m)], { type: 'application/json' }), `${this.mainName().replace(/\.[^.]+$/, '') || 'character'}.bonemap.json`);
  }

  private download(kind: 'glb' | 'bvh'): void {
    const s = this.shown;
    if (!s?.result || s.job) return;
    const base = `${this.stem}-${s.ch.name.replace(/\.[^.]+$/, '')}`;
    if (kind === 'glb') {
      saveBlob(new Blob([characterToGLB(s.ch, s.result) as BlobPart], { type: 'model/gltf-binary' }), `${base}.glb`);
    } else {
      // the unit the page's BVH download is set to (metres unless chosen otherwise)
      const units: BvhUnits = document.querySelector<HTMLSelectElement>('#dl-bvh-units')?.value === 'cm' ? 'cm' : 'm';
      const bvh = characterToBVH(s.ch.root, s.result, (o) => s.ch.json.nodes?.[s.ch.nodeIndex.get(o) ?? -1]?.name ?? o.name, units);
      saveBlob(new Blob([bvh], { type: 'text/plain' }), bvhFileName(base, units));
    }
  }

  private fail(e: unknown): void {
    const msg = e instanceof CharacterLoadError || e instanceof MappingError ? e.message : `could not use that character (${(e as Error)?.message ?? e})`;
    this.say(msg);
    this.host.notify('error', `${msg}${this.shown ? '; the current character stays' : '; the built-in character stays'}.`);
  }

  private probe(): CharacterProbe {
    const self = this;
    return {
      get active() {
        return !!self.shown?.result && !self.shown.job;
      },
      get builtInVisible() {
        return self.host.builtIn.visible;
      },
      get name() {
        return self.shown?.ch.name ?? '';
      },
      get mapped() {
        return self.shown ? 22 - self.shown.ch.unmapped.length : 0;
      },
      get status() {
        return self.status.textContent ?? '';
      },
      get comparing() {
        const s = self.shown;
        return !!s?.twin?.result && !s.twin.job && !s.job;
      },
      get retargeting() {
        return !!self.shown && (!!self.shown.job || !!self.shown.twin?.job);
      },
      get frames() {
        return self.shown?.result?.frames ?? 0;
      },
      get retargets() {
        return { ...self.stats, last: self.stats.last && { ...self.stats.last } };
      },
      jointWorld(j, copy = 'main') {
        const s = self.shown;
        const name = s?.ch.mapping[j];
        const root = copy === 'compare' ? s?.twin?.root : s?.ch.root;
        const o = name && root ? root.getObjectByName(name) : undefined;
        if (!o) return null;
        o.updateWorldMatrix(true, false);
        const e = o.matrixWorld.elements;
        return [e[12], e[13], e[14]];
      },
    };
  }

  get element(): HTMLElement {
    return this.el;
  }
}

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

/** Put every node under `copy` (a SkeletonUtils clone) at the transform of the same node under `original` (at rest). */
function restLike(copy: Object3D, original: Object3D): void {
  const a: Object3D[] = [];
  const b: Object3D[] = [];
  original.traverse((o) => a.push(o));
  copy.traverse((o) => b.push(o));
  a.forEach((o, i) => {
    b[i]?.position.copy(o.position);
    b[i]?.quaternion.copy(o.quaternion);
    b[i]?.scale.copy(o.scale);
  });
  copy.updateMatrixWorld(true);
}
