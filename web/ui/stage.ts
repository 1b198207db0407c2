// The 3-D stage: renderer, lights with soft shadows, a floor with a grid that fades into the fog, a
// camera that follows the character's root and can be orbited, and the root's path on the floor.
// Split view (the compare mode): the canvas's left half shows one character and the right half the
// other, each followed by its own camera with the same (orbited) view direction.
// Framing: the page draws a caption over the top of the canvas and the playback bar over its bottom;
// the cameras frame the band between them (CSS --stage-top / --stage-bottom on the canvas's parent),
// so the character is centred and sized in the part of the stage nothing covers.
import {
  ACESFilmicToneMapping, BufferAttribute, BufferGeometry, CanvasTexture, CircleGeometry, Color, DirectionalLight, Fog,
  GridHelper, HemisphereLight, Line, LineBasicMaterial, Mesh, MeshBasicMaterial, MeshStandardMaterial, PCFShadowMap,
  PerspectiveCamera, Scene, SkinnedMesh, SRGBColorSpace, Vector2, Vector3, WebGLRenderer, type Object3D,
} from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { RootFollower } from './follow';

const BG = 0x161b26;

/** A rectangle in page CSS pixels (like getBoundingClientRect). */
export interface ScreenRect {
  x: number;
  y: number;
  width: number;
  height: number;
}
const MAX_PATH_FRAMES = 1024;
/** The adaptive resolution's floor (CSS pixel → canvas pixels). */
const MIN_PIXEL_RATIO = 0.5;

export class Stage {
  readonly renderer: WebGLRenderer;
  readonly scene = new Scene();
  readonly camera = new PerspectiveCamera(38, 1, 0.05, 200);
  readonly controls: OrbitControls;
  private readonly sun: DirectionalLight;
  private readonly path: Line;
  private readonly pathGeometry = new BufferGeometry();
  private readonly follow = new RootFollower();
  /** split view: the right half's camera and follow point, and what each half shows */
  private readonly camera2 = new PerspectiveCamera(38, 1, 0.05, 200);
  private readonly follow2 = new RootFollower();
  private split: { left: Object3D; right: Object3D } | null = null;
  private readonly size = new Vector2();
  /** Adaptive resolution: smoothed frame time (s) and how long it has been too slow. */
  private frameTime = 1 / 60;
  private slowFor = 0;
  adaptive = true;
  private readonly tmp = new Vector3();
  /** Contact shadows under each character's root (one per split half), drawn when the shadow map is off. */
  private readonly contact = contactShadow('contact-shadow');
  private readonly contact2 = contactShadow('contact-shadow-2');
  /** CSS pixels at the top and bottom of the canvas that overlays cover (read from the page's CSS). */
  private insets = { top: 0, bottom: 0 };

  constructor(readonly canvas: HTMLCanvasElement) {
    this.renderer = new WebGLRenderer({ canvas, antialias: true, powerPreference: 'high-performance', preserveDrawingBuffer: false });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.outputColorSpace = SRGBColorSpace;
    this.renderer.toneMapping = ACESFilmicToneMapping;
    this.renderer.toneMappingExposure = 1.05;
    this.renderer.shadowMap.enabled = true;
    this.renderer.shadowMap.type = PCFShadowMap;

    this.scene.background = new Color(BG);
    this.scene.fog = new Fog(BG, 9, 26);

    const hemi = new HemisphereLight(0xdfe8ff, 0x3a3128, 1.5);
    this.scene.add(hemi);
    this.sun = new DirectionalLight(0xfff3e2, 2.6);
    this.sun.position.set(3, 6, 4);
    this.sun.castShadow = true;
    this.sun.shadow.mapSize.set(2048, 2048);
    this.sun.shadow.camera.left = -3;
    this.sun.shadow.camera.right = 3;
    this.sun.shadow.camera.top = 3;
    this.sun.shadow.camera.bottom = -3;
    this.sun.shadow.camera.near = 0.5;
    this.sun.shadow.camera.far = 20;
    this.sun.shadow.bias = -0.0004;
    this.sun.shadow.normalBias = 0.02;
    this.sun.shadow.radius = 4;
    this.scene.add(this.sun, this.sun.target);
    const rim = new DirectionalLight(0x88aaff, 0.9);
    rim.position.set(-4, 3, -5);
    this.scene.add(rim);

    const floor = new Mesh(new CircleGeometry(40, 96), new MeshStandardMaterial({ color: 0x242b38, roughness: 0.92, metalness: 0 }));
    floor.rotation.x = -Math.PI / 2;
    floor.receiveShadow = true;
    floor.name = 'floor';
    this.scene.add(floor);
    const grid = new GridHelper(80, 160, 0x4a5670, 0x323a4b);
    grid.position.y = 0.001;
    (grid.material as LineBasicMaterial).transparent = true;
    (grid.material as LineBasicMaterial).opacity = 0.55;
    this.scene.add(grid);
    this.scene.add(this.contact, this.contact2);

    // One buffer for the longest motion, updated in place (replacing attributes would leak GPU buffers).
    this.pathGeometry.setAttribute('position', new BufferAttribute(new Float32Array(MAX_PATH_FRAMES * 3), 3));
    this.pathGeometry.setDrawRange(0, 0);
    this.path = new Line(this.pathGeometry, new LineBasicMaterial({ color: 0x6f9bff, transparent: true, opacity: 0.7 }));
    this.path.frustumCulled = false;
    this.scene.add(this.path);

    this.camera.position.set(2.2, 1.5, 3.6);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.target.copy(this.follow.point);
    this.controls.enableDamping = true;
    this.controls.dampingFactor = 0.08;
    this.controls.minDistance = 1.2;
    this.controls.maxDistance = 14;
    this.controls.maxPolarAngle = Math.PI * 0.495;
    this.controls.update();
  }

  add(o: Object3D): void {
    this.scene.add(o);
  }

  /** Draw the root's ground path (frames × 3 positions, y ignored). */
  setPath(rootPos: Float32Array, frames: number): void {
    const attr = this.pathGeometry.getAttribute('position') as BufferAttribute;
    const n = Math.min(frames, MAX_PATH_FRAMES);
    const pts = attr.array as Float32Array;
    for (let i = 0; i < n; i++) {
      pts[i * 3] = rootPos[i * 3];
      pts[i * 3 + 1] = 0.004;
      pts[i * 3 + 2] = rootPos[i * 3 + 2];
    }
    attr.needsUpdate = true;
    this.pathGeometry.setDrawRange(0, n);
  }

  /**
   * Split the view: `left` is drawn only in the left half (main camera), `right` only in the right
   * half (a camera following the root given to frame() as `root2`); null = one full view again.
   */
  setSplit(split: { left: Object3D; right: Object3D } | null): void {
    this.split = split;
    this.path.visible = !split;
    // the page's CSS may move the covered bands with the view (labels on the stage in split view): read them again
    this.resize(true);
  }

  get isSplit(): boolean {
    return this.split !== null;
  }

  /** Move the orbit target (and the camera with it) towards the root (RootFollower), then render. */
  frame(dt: number, root: ArrayLike<number> | null, root2: ArrayLike<number> | null = null): void {
    if (this.adaptive) this.adapt(dt);
    if (this.split && root2) this.follow2.update(root2, dt);
    if (root) this.moveView(this.follow.update(root, dt));
    this.controls.update();
    this.resize();
    const contacts = !this.renderer.shadowMap.enabled;
    if (root) this.contact.position.set(root[0], CONTACT_Y, root[2]);
    if (root2) this.contact2.position.set(root2[0], CONTACT_Y, root2[2]);
    this.contact.visible = contacts;
    this.contact2.visible = false;
    if (!this.split) {
      this.renderer.render(this.scene, this.camera);
      return;
    }
    // split: two half-width passes, each showing one character
    const { left, right } = this.split;
    const r = this.renderer;
    r.getSize(this.size);
    const half = Math.floor(this.size.x / 2);
    const h = this.size.y;
    this.frameView(this.camera, half, h);
    this.camera2.copy(this.camera);
    this.camera2.position.add(this.tmp.copy(this.follow2.point).sub(this.follow.point));
    r.setScissorTest(true);
    const pass = (x: number, w: number, cam: PerspectiveCamera, show: Object3D, hide: Object3D) => {
      show.visible = true;
      hide.visible = false;
      this.contact.visible = contacts && show === left;
      this.contact2.visible = contacts && show === right;
      r.setViewport(x, 0, w, h);
      r.setScissor(x, 0, w, h);
      r.render(this.scene, cam);
    };
    pass(0, half, this.camera, left, right);
    pass(half, this.size.x - half, this.camera2, right, left);
    left.visible = true;
    right.visible = true;
    r.setScissorTest(false);
    r.setViewport(0, 0, this.size.x, h);
    this.frameView(this.camera, this.size.x, h);
  }

  /**
   * Point a camera at a view of width × height CSS pixels whose top and bottom insets are covered by
   * overlays: its field of view spans the band between them (a view offset), so what the camera
   * frames is centred in the uncovered band and the covered strips show only the scene around it.
   */
  private frameView(cam: PerspectiveCamera, width: number, height: number): void {
    const band = Math.max(1, height - this.insets.top - this.insets.bottom);
    cam.aspect = width / band;
    if (band < height) cam.setViewOffset(width, band, 0, -this.insets.top, width, height);
    else cam.clearViewOffset();
    cam.updateProjectionMatrix();
  }

  /** Snap the right half's follow point to a root (split view). */
  snapTo2(root: ArrayLike<number>): void {
    this.follow2.snap(root);
  }

  /** Snap the follow point to the root (used when a new motion starts far away). */
  snapTo(root: ArrayLike<number>): void {
    this.moveView(this.follow.snap(root));
  }

  /** Move the orbit target, the camera and the sun's shadow box by `delta` (the follow point's move). */
  private moveView(delta: Vector3): void {
    this.controls.target.add(delta);
    this.camera.position.add(delta);
    const p = this.follow.point;
    this.sun.position.set(p.x + 3, 6, p.z + 4);
    this.sun.target.position.set(p.x, 0, p.z);
  }

  /**
   * Software WebGL (no GPU) can take hundreds of ms per frame at full resolution: when frames stay
   * slower than ~30 fps for 1.5 s, lower the pixel ratio step by step (to 0.5), then drop shadows.
   */
  private adapt(dt: number): void {
    if (dt <= 0) return;
    this.frameTime += (dt - this.frameTime) * 0.1;
    this.slowFor = this.frameTime > 1 / 30 ? this.slowFor + dt : 0;
    if (this.slowFor < 1.5) return;
    this.slowFor = 0;
    this.frameTime = 1 / 60;
    const pr = this.renderer.getPixelRatio();
    if (pr > MIN_PIXEL_RATIO) this.renderer.setPixelRatio(Math.max(MIN_PIXEL_RATIO, pr * 0.7));
    else if (this.renderer.shadowMap.enabled) this.dropShadows();
  }

  /** The lowest quality at once (URL `quality=low`): the smallest pixel ratio, no shadows, no further adapting. */
  lowest(): void {
    this.adaptive = false;
    this.renderer.setPixelRatio(MIN_PIXEL_RATIO);
    this.dropShadows();
    this.resize(true);
  }

  private dropShadows(): void {
    this.renderer.shadowMap.enabled = false;
    this.scene.traverse((o) => {
      const m = (o as { material?: { needsUpdate: boolean } }).material;
      if (m) m.needsUpdate = true;
    });
  }

  /**
   * Where the characters are on the page now (CSS pixels, like getBoundingClientRect): for each visible
   * object holding a SkinnedMesh (in split view: the left and the right one, each in its half), the
   * screen box of its posed mesh (every vertex skinned by the current bones, projected through the
   * camera that draws it). For layout checks: nothing drawn over the page should cover these.
   */
  characterRects(): ScreenRect[] {
    this.scene.updateMatrixWorld();
    const page = this.canvas.getBoundingClientRect();
    const w = page.width;
    const h = page.height;
    const half = Math.floor(w / 2);
    const views: Array<{ objects: Object3D[]; camera: PerspectiveCamera; x: number; width: number }> = this.split
      ? [{ objects: [this.split.left], camera: this.camera, x: 0, width: half }, { objects: [this.split.right], camera: this.camera2, x: half, width: w - half }]
      : [{ objects: this.scene.children.filter((o) => o.visible && hasSkinnedMesh(o)), camera: this.camera, x: 0, width: w }];
    const rects: ScreenRect[] = [];
    for (const view of views) {
      const cam = view.camera.clone();
      this.frameView(cam, view.width, h);
      cam.updateMatrixWorld();
      for (const o of view.objects) {
        const b = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
        forEachPosedVertex(o, (v) => {
          v.project(cam);
          const px = page.left + view.x + ((v.x + 1) / 2) * view.width;
          const py = page.top + ((1 - v.y) / 2) * h;
          b.x0 = Math.min(b.x0, px); b.x1 = Math.max(b.x1, px); b.y0 = Math.min(b.y0, py); b.y1 = Math.max(b.y1, py);
        });
        if (b.x0 <= b.x1) rects.push({ x: b.x0, y: b.y0, width: b.x1 - b.x0, height: b.y1 - b.y0 });
      }
    }
    return rects;
  }

  /** Current quality (for the test API / diagnostics). */
  get quality(): { pixelRatio: number; shadows: boolean } {
    return { pixelRatio: this.renderer.getPixelRatio(), shadows: this.renderer.shadowMap.enabled };
  }

  private resize(force = false): void {
    const c = this.canvas;
    const w = c.clientWidth;
    const h = c.clientHeight;
    if (w === 0 || h === 0) return;
    const pr = this.renderer.getPixelRatio();
    if (force || c.width !== Math.floor(w * pr) || c.height !== Math.floor(h * pr)) {
      this.renderer.setSize(w, h, false);
      const css = c.parentElement ? getComputedStyle(c.parentElement) : null;
      const px = (name: string) => Math.max(0, parseFloat(css?.getPropertyValue(name) ?? '') || 0);
      this.insets = { top: px('--stage-top'), bottom: px('--stage-bottom') };
      this.frameView(this.camera, w, h);
    }
  }
}

/** Height of the contact shadows: above the grid (1 mm), below the root path (4 mm). */
const CONTACT_Y = 0.002;

/**
 * A soft dark disc on the floor (radius 0.6 m, darkest at its centre: a step's feet stay on it): where the character stands when the shadow
 * map is off (the lowered quality of slow frames, `quality=low`), so its feet still meet a visible floor.
 */
function contactShadow(name: string): Mesh {
  const size = 64;
  const c = document.createElement('canvas');
  c.width = c.height = size;
  const g = c.getContext('2d')!;
  const grad = g.createRadialGradient(size / 2, size / 2, 0, size / 2, size / 2, size / 2);
  grad.addColorStop(0, 'rgba(0, 0, 0, 0.6)');
  grad.addColorStop(0.6, 'rgba(0, 0, 0, 0.3)');
  grad.addColorStop(1, 'rgba(0, 0, 0, 0)');
  g.fillStyle = grad;
  g.fillRect(0, 0, size, size);
  const m = new Mesh(new CircleGeometry(0.6, 48), new MeshBasicMaterial({ map: new CanvasTexture(c), transparent: true, depthWrite: false }));
  m.rotation.x = -Math.PI / 2;
  m.position.y = CONTACT_Y;
  m.name = name;
  m.visible = false;
  return m;
}

function hasSkinnedMesh(o: Object3D): boolean {
  let found = false;
  o.traverseVisible((c) => (found ||= c instanceof SkinnedMesh));
  return found;
}

/** Every vertex of an object's visible meshes in world space, as posed now (skinned meshes skinned). */
function forEachPosedVertex(o: Object3D, fn: (v: Vector3) => void): void {
  const v = new Vector3();
  o.traverseVisible((c) => {
    if (!(c instanceof Mesh)) return;
    const n = c.geometry.getAttribute('position').count;
    for (let i = 0; i < n; i++) fn(c.getVertexPosition(i, v).applyMatrix4(c.matrixWorld));
  });
}
