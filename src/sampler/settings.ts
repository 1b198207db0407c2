/**
 * How to sample, as ONE object from the library's request to the sampler loop (Python: `emdm.sampler`'s
 * `SamplingSettings`, the same fields: `guidance_min_time` is `guidanceMinTime` and so on;
 * tests/unit/sampling-settings.test.ts reads both). Python's `z_dim`/`feature_dim`, the model's shapes, are
 * `SampleOptions`' `zDim`/`featureDim` here: openModel takes them from the manifest, never from a request.
 *
 * A request (createGenerator's `MotionRequest`, openModel's `GenerateOptions`) gives its `RequestSettings`, every
 * field optional there (the model's manifest entry fills the rest), and its inpainting as `known`, a de-normalised
 * `KnownMotion`; openModel turns that into the settings' normalised `known`, `keep` and `keepFromTime`
 * (`inpaintingSettings`), and `sample()` reads the settings as they came: each field is declared and documented here only.
 */
import { normalizeFeatures } from '../motion/recover';
import type { KnownMotion } from './mask';

/** An update rule of the sampler registry (src/sampler/registry.ts): the built-in 'ddgan' and 'ddim', or a registered one. */
export type SamplerName = 'ddgan' | 'ddim' | (string & {});

/** The update rule a manifest `objective` calls for: "diffusion" → 'ddim', else (absent, "ddgan") 'ddgan' (Python `method_of`). */
export function methodOf(objective: string | undefined): SamplerName {
  return objective === 'diffusion' ? 'ddim' : 'ddgan';
}

export interface SamplingSettings {
  /**
   * The update rule (src/sampler/registry.ts): 'ddgan' (the EMDM posterior, a fresh z and ε every step) for models of
   * objective "ddgan", 'ddim' (η = 0) for objective "diffusion". Default: the one the model's objective calls for.
   */
  method?: SamplerName;
  /** denoising steps: one of the model's supportedSteps (default: its defaultSteps) */
  steps: number;
  /** classifier-free guidance scale; 1 (or an all-zero condition) = a single conditional pass (default: the model's) */
  guidance: number;
  /**
   * Guidance in a limited interval (Kynkäänniemi et al. 2024; the manifest's `guidanceMinTime`): the unconditional
   * row runs only at steps whose time is above this; the other steps are one conditional row (x̂0 = x̂0(c)), half the
   * work. The random draws do not depend on it (z is drawn once per step for both rows), so only the unguided steps'
   * x̂0 changes. Default: the model's manifest `guidanceMinTime`, else 0 = every step is guided.
   */
  guidanceMinTime?: number;
  /**
   * Smoothing x̂0 along time (σ in frames; docs/ARCHITECTURE.md "Sampling"): at every step but the last, after
   * guidance and before the kept part is replaced, x̂0's pose channels (root-relative positions and rotations,
   * `POSE_CHANNELS`) are filtered along frames with `smoothJoints`' Gaussian (`smoothPose`) — what is re-noised for
   * the next step is then one coherent pose sequence rather than per-frame phase choices; the root, velocity and
   * contact channels stay the model's. The last x̂0 (the result) is the model's own. Default: the model's manifest
   * `x0Smoothing`, else 0 = off, bit for bit; the random draws do not depend on it.
   */
  x0Smoothing?: number;
  /**
   * Root speed cap (docs/MODELS.md "A cap on the sampler's side"): each motion goes at most this multiple of its first
   * step's conditional x̂0's median horizontal root speed (t = 1: the condition's mean motion, which travels at the
   * real clips' speed; the later steps made runs a fifth faster). A motion whose first x̂0 travels (≥ 0.5 m/s,
   * `CAP_MIN_SPEED`) and whose result goes faster has its root velocity channels 1–2 scaled to the cap on the entries
   * not kept (the model's `rootNorm` de-normalises them); never faster; heading, pose and the rest are the model's.
   * Default: the model's manifest `speedCap`, else 0 = off, bit for bit; the random draws do not depend on it.
   */
  speedCap?: number;
  /**
   * Inpainting (docs/ARCHITECTURE.md "Sampling with constraints"): a known motion [L, D] in NORMALISED feature space
   * (a request's de-normalised `KnownMotion.features` through the model's mean/std: `inpaintingSettings`), kept where
   * `keep` is 1. x_T's kept part becomes aCum[T]·known + sCum[T]·x_T and x̂0's kept part is replaced by `known` before
   * every update, so the model sees the known motion noised to each step's level and the result equals `known`
   * exactly where keep = 1. Give both or neither (a run that stops before the kept part is imposed may give `keep` alone).
   */
  known?: Float32Array;
  /** the 0/1 mask [L, D] (`keepMask`) of `known`'s entries to keep */
  keep?: Float32Array;
  /**
   * The kept part is imposed only at the steps whose time t_k ≤ keepFromTime (x_T's when the first step's is)
   * and always at the last step: the earlier steps are shaped by the condition alone, the later ones reconcile
   * the motion with the known part (a timeline window: src/edit.ts TIMELINE_KEEP_FROM). Absent or 1: every step.
   * The frames kept on every channel at the start (`leadFrames`: a window's context) sit the earlier steps out: the
   * model sees frames [lead, L) only, a generation of its own, and they join at the first imposing step k as
   * aCum[k+1]·known + sCum[k+1]·(their x_T draw), the known motion noised to that step's level. That saves their
   * rows at the steps they would not shape and leaves a window's early steps independent of what it continues.
   * The random draws do not depend on it (x_T and every ε are drawn for all L frames; the rows left out go unused).
   */
  keepFromTime?: number;
}

/** The inpainting fields of SamplingSettings: in a request they arrive together as its de-normalised `known` (KnownMotion). */
export type InpaintingField = 'known' | 'keep' | 'keepFromTime';

/** SamplingSettings as a request gives them: all but inpainting, which a request gives as `known: KnownMotion`. */
export type RequestSettings = Omit<SamplingSettings, InpaintingField>;

/**
 * A request's known motion as the sampler's inpainting settings: its features normalised with the model's `mean`/`std`
 * (`normalizeFeatures`), its `keep`, and `fromTime` as `keepFromTime`. A request of `Generator.begin` that stops
 * before the kept part is imposed may carry `keep` without `features`; no known motion gives no fields.
 */
export function inpaintingSettings(
  known: (Omit<KnownMotion, 'features'> & { features?: Float32Array }) | undefined, mean: Float32Array, std: Float32Array,
): Pick<SamplingSettings, InpaintingField> {
  if (!known) return {};
  return { ...(known.features ? { known: normalizeFeatures(known.features, mean, std) } : {}), keep: known.keep, keepFromTime: known.fromTime };
}
