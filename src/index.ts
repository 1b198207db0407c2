/**
 * emdm-web, the library's public surface (docs/ARCHITECTURE.md "TypeScript library"): text / action → 3-D human
 * motion, edits of it, and its export and retargeting.
 *
 * ```ts
 * import { createGenerator, writeBVH } from 'emdm-web';
 * const generator = await createGenerator();                  // <BASE_URL>models/, in a Web Worker, WebGPU → WASM
 * const motion = await generator.generate({ prompt: 'a person walks forward', seconds: 4 });
 * const bvh = writeBVH(motion, generator.skeleton);            // motion.joints, motion.pose: play it with 'emdm-web/three'
 * ```
 *
 * The three.js character and player are the second entry, 'emdm-web/three' (src/three.ts). Nothing else under
 * src/ is part of the package's API: the generation worker's protocol, one-model generators (openModel, loadModel),
 * the backend fallback, the sampler's update rules and the motion math are internals that the demo page (web/) and
 * the tests import by path, and that may change in any release.
 */

// ── the generator: createGenerator and what its calls take and give ─────────────────────────────────────────────
export { createGenerator } from './createGenerator';
export type { BeginRequest, CreateGeneratorOptions, GeneratedMotion, GeneratedTimeline, LiveCallOptions, MotionGenerator, MotionRequest, TimelineCallOptions } from './createGenerator';
/** generator.live's stream: frames pulled by time, prompts that change what comes next (src/live/stream.ts) */
export type { LiveFrame, LiveStats, LiveStream } from './live/stream';
export type { RequestSettings, SamplerName, SamplingSettings } from './sampler/settings';
export type { Motion } from './motion/types';
export type { SampleState } from './openModel';
export type { WindowRun } from './worker/generationHost';
export type { PromptCheck } from './capabilities';
/** whether a prompt reads as English (the text encoder and the captions are English; the page's notice says so) */
export { readsAsEnglish } from './language';
export type { Backend, BackendRequest } from './runtime/ort';
/** the models folder's manifest (createGenerator loads it, or takes one) and the error a bad model file raises */
export { ModelFileError, loadManifest } from './manifest';
export type { Manifest, ModelEntry } from './manifest';
/** errors a generation rejects with: cancelled (AbortSignal), or NaN / ±Infinity in the model's output */
export { AbortError } from './sampler/sampler';
export { NonFiniteMotionError } from './errors';
/** the verified model files kept in Cache Storage between visits (the worker's cache, `cache: true`) */
export { clearModelCache, modelCacheUsage } from './cache/modelCache';
/** the 22 SMPL-order joints every motion uses (`generator.skeleton` holds their rest offsets) */
export { JOINT_NAMES, KINEMATIC_CHAINS, PARENTS } from './skeleton';
export type { JointName, Skeleton, SkeletonLike } from './skeleton';

// ── edits: timelines, in-betweening, body-part edits and loops (inpainting with `known`, `keepMask`) ────────────
export { EditError, LOOP_END_FRAMES, MAX_TIMELINE_SECONDS, bodyPartEdit, generateTimeline, inBetween, makeLoop, withNewSeed } from './edit';
export type { EditBegin, EditBeginRequest, EditCondition, EditGenerate, EditLimits, EditMotion, EditRequest, KeptPart, LoopResult, SegmentResult, Timeline, TimelineOptions, TimelineSegment } from './edit';
export { FEATURE_GROUPS, KeepSpecError, keepMask, parseKeep } from './sampler/mask';
export type { FeatureGroup, KeepRect, KnownMotion } from './sampler/mask';

// ── exporters: BVH of the built-in skeleton, BVH and GLB of a user's character ───────────────────────────────────
export { type BvhUnits, bvhFileName, writeBVH } from './export/bvh';
export { characterToBVH, characterToGLB, fileBoneNames } from './export/characterGlb';
export { type JointsDocument, motionToJSON } from './export/jointsJson';

// ── a user's character: load a glTF/VRM/FBX file, map its bones, retarget a motion onto it ─────────────────────
export { CharacterLoadError, MAX_CHARACTER_BYTES, loadCharacter } from './character/retarget/load';
export type { CharacterFile, CharacterLoadReason, LoadCharacterOptions, LoadedCharacter } from './character/retarget/load';
export { MappingError, REQUIRED_JOINTS, autoMap, mappingFromJSON, mappingToJSON, validateMapping } from './character/retarget/mapping';
export type { AutoMapResult, BoneInfo, BoneMapping } from './character/retarget/mapping';
export { retargetMotion, retargetMotionAsync } from './character/retarget/retarget';
export type { RetargetMotion, RetargetOptions, RetargetResult, RetargetSliceOptions } from './character/retarget/retarget';
