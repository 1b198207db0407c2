// The package's entry (src/index.ts) is a documented public surface: the generator and its types, edits, exporters
// and the user's character — not the internals behind them (the worker protocol, one-model generators, the backend
// fallback, the sampler's update rules, the motion math), which web/ and the tests import by path.
import { describe, expect, it } from 'vitest';
import * as lib from '../../src/index';

const PUBLIC = [
  // the generator, its errors, the manifest and the model cache
  'AbortError', 'ModelFileError', 'NonFiniteMotionError', 'clearModelCache', 'createGenerator', 'loadManifest', 'modelCacheUsage',
  'JOINT_NAMES', 'KINEMATIC_CHAINS', 'PARENTS',
  // whether a prompt reads as English (the unknown-prompt notice says so; src/language.ts)
  'readsAsEnglish',
  // edits
  'EditError', 'FEATURE_GROUPS', 'KeepSpecError', 'LOOP_END_FRAMES', 'MAX_TIMELINE_SECONDS', 'bodyPartEdit', 'generateTimeline', 'inBetween',
  'keepMask', 'makeLoop', 'parseKeep', 'withNewSeed',
  // exporters
  'bvhFileName', 'characterToBVH', 'characterToGLB', 'fileBoneNames', 'motionToJSON', 'writeBVH',
  // a user's character
  'CharacterLoadError', 'MAX_CHARACTER_BYTES', 'MappingError', 'REQUIRED_JOINTS', 'autoMap', 'loadCharacter', 'mappingFromJSON', 'mappingToJSON',
  'retargetMotion', 'retargetMotionAsync', 'validateMapping',
];

describe('src/index.ts', () => {
  it('exports the public surface and nothing else', () => {
    expect(Object.keys(lib).sort()).toEqual([...PUBLIC].sort());
  });

  it('leaves the internals out: wire types\' client, generators of one model, fallback, update rules, motion math', () => {
    for (const name of ['GenerationClient', 'openModel', 'loadModel', 'runWithFallback', 'withFallback', 'ddimUpdate', 'ddganUpdate', 'sample',
      'lockstep', 'together', 'SeededRandom', 'computeSchedule', 'solveIK', 'recoverJoints', 'decodeJoints', 'resolveRequest', 'beginByModel']) {
      expect(name in lib, name).toBe(false);
    }
  });
});
