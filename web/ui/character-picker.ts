// "Your character": drop (or pick) a .glb/.gltf/.vrm and it replaces the built-in character on the
// stage, performing the motion on screen (src/character/retarget: load → bone map → retarget); one
// click brings the built-in character back. Joints the automatic map missed can be picked in a small
// editor; the map is kept per file name in localStorage and can be exported as JSON. Downloads: the
// character with the clip as GLB, and the clip as BVH on its bone names.
// Retargeting runs in slices (retargetMotionAsync: ~8 ms of work, then the page draws), so a 60 s motion
// does not freeze the page; a newer motion cancels the one being put on the character (newest wins), and
// the character plays its previous clip until the new one is ready.
// This file loads and swaps the characters; character-performer.ts puts a motion on one copy, and
// bone-map-editor.ts is the editor and the kept maps.
import { Group, type Object3D } from 'three';
import { clone as cloneSkinned } from 'three/addons/utils/SkeletonUtils.js';
import { type CharacterFile, CharacterLoadError, type LoadedCharacter, loadCharacter, type BoneMapping, MappingError, mappingToJSON, validateMapping, type BvhUnits, bvhFileName, characterToBVH, characterToGLB, fileBoneNames, type Motion, type JointName, type Skeleton } from '../../src/index';
import { BoneMapEditor, saveMap, savedMap } from './bone-map-editor';
import { type Performer, type RetargetStats, drop, perform, poseAt } from './character-performer';
import { saveBlob } from './dom';

export type { RetargetStats } from './character-performer';

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

const ACCEPT = '.glb,.gltf,.vrm,.bin,.png,.jpg,.jpeg,.webp,.ktx2';

interface Shown extends Performer {
  ch: LoadedCharacter;
  /** the compare view's second copy (the DDIM motion), made when a comparison is shown */
  twin: Performer | null;
  /** what the status line says about it once its motion is on it */
  summary: string;
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

/** Why the downloads on the visitor's character are off in live mode. */
export const LIVE_CHARACTER_NOTE = 'Live mode: your character plays the stream. Its GLB and BVH come back when live mode stops (with the last recording, if any).';

export class CharacterPicker {
  private shown: Shown | null = null;
  private motion: Motion | null = null;
  /** the clock's time of the motion's first frame (a piece of the live stream; 0 otherwise) */
  private start = 0;
  /** the motion is a piece of the live stream: its retargeting is not announced (one every ~2 s) */
  private piece = false;
  /**
   * Live mode: the stream's stage origin (x, z, metres: world = stage + origin) of what plays now, of the newest piece
   * and of the piece on the character. The stage moves back under what plays by whole metres as a walk goes on; until a
   * piece cut on the new stage is on the character (a retarget: 0.1–0.6 s), the old one is drawn moved by the
   * difference of origins (it stood a metre off the stream's root meanwhile). [0, 0] outside live mode.
   */
  private stageOrigin: readonly [number, number] = [0, 0];
  private motionOrigin: readonly [number, number] = [0, 0];
  private shownOrigin: readonly [number, number] = [0, 0];
  /** the compare view's second motion (DDIM), null when not comparing */
  private compareMotion: Motion | null = null;
  private stem = 'emdm';
  private files: CharacterFile[] = [];
  private readonly el: HTMLElement;
  private readonly status: HTMLElement;
  private readonly back: HTMLButtonElement;
  private readonly editor: BoneMapEditor;
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
      </div>
      <p id="char-dl-note" class="hint" hidden>${LIVE_CHARACTER_NOTE}</p>`;
    host.before.parentElement!.insertBefore(el, host.before);
    this.el = el;
    const q = <T extends HTMLElement>(id: string) => el.querySelector<T>(`#${id}`)!;
    this.status = q('char-status');
    this.back = q<HTMLButtonElement>('char-builtin');
    this.editor = new BoneMapEditor(q<HTMLDetailsElement>('char-map'), q('char-map-rows'));
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

  /** The motion on screen changed (live mode: a piece of the stream from the clock's time `start`): put it on the user's character (if one is shown). */
  setMotion(motion: Motion, stem: string, start?: number, origin: readonly [number, number] = [0, 0]): void {
    this.motion = motion;
    this.start = start ?? 0;
    this.piece = start !== undefined;
    this.motionOrigin = origin;
    if (!this.piece) this.stageOrigin = origin;
    this.stem = stem;
    if (this.piece) this.setDownloads(false); // off at once: the stream's pieces are not a motion to save
    if (this.shown) this.retarget().catch((e) => this.fail(e));
  }

  /** Live mode: the stage origin of the frame shown now. A piece cut on another stage is drawn moved onto this one. */
  stageAt(origin: readonly [number, number]): void {
    if (origin[0] === this.stageOrigin[0] && origin[1] === this.stageOrigin[1]) return;
    this.stageOrigin = origin;
    this.place();
  }

  /** Draw the character's clip where its stage is now (see stageOrigin). */
  private place(): void {
    const h = this.shown?.holder;
    if (!h) return;
    h.position.x = this.shownOrigin[0] - this.stageOrigin[0];
    h.position.z = this.shownOrigin[1] - this.stageOrigin[1];
  }

  /** Live mode ended: the stream's pieces are over. The downloads stay off until a motion is put on the character
   * (setMotion: the one shown before live mode, or the recording), and the live note goes. */
  leaveLive(): void {
    if (!this.piece) return;
    this.piece = false;
    this.stageOrigin = this.motionOrigin = this.shownOrigin = [0, 0];
    this.place();
    this.setDownloads(false);
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
      if (s.twin) drop(s.twin);
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
    perform(twin, motion, s.ch, this.host.skeleton, this.stats).catch((e) => {
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

  async open(list: File[]): Promise<void> {
    this.say(`Reading ${list.map((f) => f.name).join(', ')}…`);
    try {
      this.files = await Promise.all(list.map(async (f) => ({ name: f.name, data: await f.arrayBuffer() })));
      await this.load(savedMap(this.mainName()));
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
        this.editor.show(e.bones, e.mapping ?? {});
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
        const origin = this.motionOrigin;
        if (!(await perform(next, motion, ch, this.host.skeleton, this.stats, (f) => this.say(`Putting the motion on ${ch.name}… ${Math.round(f * 100)}%`), this.start))) return;
        this.shownOrigin = origin;
      } finally {
        if (this.pending === next) this.pending = null;
      }
      if (token !== this.loads) return;
    }
    this.useBuiltIn(false);
    this.host.add(holder);
    this.shown = next;
    this.place();
    poseAt(next, this.host.time()); // on the stage posed, not at rest until the next frame's update
    this.host.builtIn.visible = false;
    this.back.hidden = false;
    this.editor.show(ch.boneInfos, ch.mapping);
    this.say(summary);
    this.setDownloads(!!next.result);
    if (this.motion !== motion) this.retarget().catch((e) => this.fail(e)); // a newer motion came meanwhile
    if (this.compareMotion) this.compare(this.compareMotion);
    this.host.changed?.();
  }

  /** Put the motion on screen on the visitor's character (the previous clip plays until it is ready). */
  private async retarget(): Promise<void> {
    const s = this.shown;
    if (!s || !this.motion) return;
    s.ch.restPose();
    this.setDownloads(false);
    const name = s.ch.name;
    const say = this.piece ? undefined : (f: number) => this.say(`Putting the motion on ${name}… ${Math.round(f * 100)}%`);
    const origin = this.motionOrigin;
    const running = perform(s, this.motion, s.ch, this.host.skeleton, this.stats, say, this.start);
    // its first slice read the rest pose (restPose above) before perform returned: the clip playing now poses the
    // character again at once, or a retarget begun while a frame is drawn (live mode, the stage moved) shows the rest pose
    poseAt(s, this.host.time());
    const done = await running;
    if (!done || this.shown !== s) return;
    this.shownOrigin = origin; // the new clip plays from this frame on: drawn where its stage is now
    this.place();
    poseAt(s, this.host.time()); // posed now (its mixer left the bones at rest), not at the next frame's update
    this.setDownloads(true);
    if (this.status.textContent !== s.summary) this.say(s.summary);
  }

  private update(): void {
    const s = this.shown;
    for (const p of [s, s?.twin]) poseAt(p, this.host.time());
  }

  useBuiltIn(say = true): void {
    if (say) {
      this.loads++; // the visitor's choice: a character still loading does not replace it
      this.pending?.job?.abort();
    }
    const s = this.shown;
    if (s) {
      drop(s);
      if (s.twin) drop(s.twin);
      this.shown = null;
    }
    this.host.builtIn.visible = true;
    const hadFocus = document.activeElement === this.back;
    this.back.hidden = true;
    if (hadFocus) document.getElementById('char-open')?.focus(); // the hidden button held the keyboard focus
    this.setDownloads(false);
    if (say) {
      this.editor.editor.hidden = true;
      this.say('');
      if (s) this.host.changed?.();
    }
  }

  private async applyEditor(): Promise<void> {
    const m = this.editor.edited();
    try {
      validateMapping(m, this.editor.bones);
      await this.load(m);
      saveMap(this.mainName(), m);
    } catch (e) {
      this.fail(e);
    }
  }

  private exportMap(): void {
    const m = this.editor.edited();
    saveBlob(new Blob([mappingToJSON(m)], { type: 'application/json' }), `${this.mainName().replace(/\.[^.]+$/, '') || 'character'}.bonemap.json`);
  }

  /**
   * The GLB/BVH-on-it buttons: on with a motion on the character, except while it plays pieces of the live stream
   * (they would write the last ~2 s piece; #char-dl-note says why, and the page's downloads save a recording).
   */
  private setDownloads(ready: boolean): void {
    const note = this.el.querySelector<HTMLElement>('#char-dl-note')!;
    note.hidden = !this.piece || !this.shown;
    for (const b of [this.dlGlb, this.dlBvh]) {
      b.disabled = !ready || this.piece;
      if (!note.hidden) b.setAttribute('aria-describedby', 'char-dl-note');
      else b.removeAttribute('aria-describedby');
    }
  }

  private download(kind: 'glb' | 'bvh'): void {
    const s = this.shown;
    if (!s?.result || s.job || this.piece) return;
    const base = `${this.stem}-${s.ch.name.replace(/\.[^.]+$/, '')}`;
    if (kind === 'glb') {
      saveBlob(new Blob([characterToGLB(s.ch, s.result) as BlobPart], { type: 'model/gltf-binary' }), `${base}.glb`);
    } else {
      // the unit the page's BVH download is set to (metres unless chosen otherwise)
      const units: BvhUnits = document.querySelector<HTMLSelectElement>('#dl-bvh-units')?.value === 'cm' ? 'cm' : 'm';
      const bvh = characterToBVH(s.ch.root, s.result, fileBoneNames(s.ch), units);
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
