/**
 * How to sample, as ONE object from the library's request to the sampler loop (Python: `emdm.sampler`'s
 * `SamplingSettings`, the same names). createGenerator's `MotionRequest` takes it with every field optional (the
 * model's manifest entry fills the rest), the generation host and `Generator.generate` take it filled in, and
 * `sample()` reads it as it came: each field is declared and documented here only.
 */

/** An update rule of the sampler registry (src/sampler/registry.ts): the built-in 'ddgan' and 'ddim', or a registered one. */
export type SamplerName = 'ddgan' | 'ddim' | (string & {});

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
}
