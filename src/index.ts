// Public surface of the EMDM-in-the-browser library (docs/ARCHITECTURE.md "TypeScript library").
export { beginByModel, createGenerator, modelFor, resolveRequest } from './createGenerator';
export type { BeginRequest, CreateGeneratorOptions, GeneratedMotion, GeneratedTimeline, MotionGenerator, MotionRequest, TimelineCallOptions } from './createGenerator';
// one model on one backend, and the backend choice / fallback (used by createGenerator's host)
export { openModel } from './generate';
export type { BeginOptions, Condition, GenerateOptions, GenerateResult, Generator, GeneratorOptions, Motion, SampleState, StepPreview } from './generate';
export { loadModel, runWithFallback, withFallback } from './backends';
export type { LoadModelOptions } from './backends';
// the generation worker's page side (createGenerator uses it; the demo page drives it directly)
export { GenerationClient } from './worker/client';
export type { ClientEvents, FileEvent, GenerationClientOptions, ModelInfo, RemoteGenerateOptions, RemoteResult, RemoteTimelineOptions, RemoteTimelineResult, WirePose, WireStepPreview, WorkerEnvironment } from './worker/client';
export type { TimelineHooks, TimelineRequest, TimelineResult, WindowRun } from './worker/host';
export type { WireBeginOptions } from './worker/protocol';
export { clearModelCache, modelCacheUsage, useModelCache } from './cache/modelCache';
export { capabilitiesFile, checkPrompt, loadCapabilities, validateCapabilities } from './capabilities';
export type { ActionCapability, Capabilities, PromptCheck, RealSpeed } from './capabilities';
export { loadManifest, fetchVerified, ModelFileError, sha256Hex, chooseVariant, stepFileOf } from './manifest';
export { assertFinite, NonFiniteMotionError } from './errors';
export type { Manifest, ModelEntry } from './manifest';
export { JOINT_NAMES, PARENTS, KINEMATIC_CHAINS, SkeletonFormatError, checkSkeleton, standardJoints } from './skeleton';
export type { JointName, Skeleton, SkeletonLike } from './skeleton';
export { createTextEncoder } from './text';
export type { TextEncoder } from './text';
export { solveIK, forwardKinematics } from './motion/ik';
export type { IKResult } from './motion/ik';
export { recoverJoints, denormalize } from './motion/recover';
export { smoothJoints } from './motion/smooth';
export { decodeJoints, type DecodeOptions } from './motion/decode';
export { alignSegment, appendSegment, headingAt, pinKeptRoot, pinRoot, rootPose } from './motion/stitch';
export { cleanupFootContacts, contactsFromFeatures, footSkate, plantContacts } from './motion/footContact';
export { type BvhUnits, bvhFileName, writeBVH } from './export/bvh';
export { characterToBVH, characterToGLB } from './export/characterGlb';
export { CharacterLoadError, MAX_CHARACTER_BYTES, loadCharacter } from './character/retarget/load';
export type { CharacterFile, CharacterLoadReason, LoadCharacterOptions, LoadedCharacter } from './character/retarget/load';
export { MappingError, REQUIRED_JOINTS, autoMap, mappingFromJSON, mappingToJSON, validateMapping } from './character/retarget/mapping';
export type { AutoMapResult, BoneInfo, BoneMapping } from './character/retarget/mapping';
export { retargetMotion, retargetMotionAsync } from './character/retarget/retarget';
export type { RetargetMotion, RetargetOptions, RetargetResult, RetargetSliceOptions } from './character/retarget/retarget';
export { SeededRandom } from './sampler/rng';
export type { RandomState } from './sampler/rng';
export { lockstep, together } from './sampler/lockstep';
export { computeSchedule, ddimScheduleFor, scheduleFor } from './sampler/schedule';
export type { DdimSchedule, Schedule } from './sampler/schedule';
export { ddimUpdate } from './sampler/ddim';
export { AbortError } from './sampler/sampler';
// beyond one prompt: timelines, in-betweening, body-part edits and loops (inpainting with known/keep)
export {
  EditError, LOOP_END_FRAMES, MAX_TIMELINE_SECONDS, OVERLAP_FRAMES, TIMELINE_KEEP_FROM, bodyPartEdit, generateTimeline, inBetween, keptSegments, makeLoop,
  planTimeline, stitchTimeline, withNewSeed,
} from './edit';
export type { EditBegin, EditBeginRequest, EditCondition, EditGenerate, EditLimits, EditMotion, EditRequest, KeptPart, LoopResult, SegmentResult, Timeline, TimelineOptions, TimelinePlan, TimelineSegment } from './edit';
export { FEATURE_GROUPS, GROUP_JOINTS, KeepSpecError, groupChannels, keepMask, parseKeep } from './sampler/mask';
export type { FeatureGroup, KeepRect, KnownMotion } from './sampler/mask';
export type { NoiseSource, SamplerName } from './sampler/sampler';
export { webgpuAvailable } from './runtime/ort';
export type { Backend, BackendRequest } from './runtime/ort';
