// The live tests' cheap generator (tests/unit/live*.test.ts): the windows' bookkeeping is what they test, not a model.
import type { EditMotion, EditRequest } from '../../src/edit';
import { recoverJoints } from '../../src/motion/recover';

const D = 263;
/** A walk forward at 1.3 m/s (features), its arms at a height set by the action and seed; kept frames as known.
 * `jitter` (m): every joint shakes sideways by ± that much from frame to frame (a raw model's jitter). */
export function walk(r: EditRequest, jitter = 0): EditMotion {
  const f = new Float32Array(r.frames * D);
  const lift = 0.1 * ('abcdefgh'.indexOf(String(r.action)) + 1) + 0.01 * (r.seed % 7);
  for (let t = 0; t < r.frames; t++) {
    const row = f.subarray(t * D, (t + 1) * D);
    row[2] = 0.065;
    row[3] = 0.9 + 0.02 * Math.sin(t / 3);
    for (let j = 0; j < 21; j++) {
      const side = j % 2 ? 1 : -1; // odd: left (+x), as l_hip (1) and l_shoulder (16, even: fixed below)
      row[4 + 3 * j] = side * 0.15;
      row[5 + 3 * j] = 0.1 + 0.08 * j + (j >= 15 ? lift * Math.sin(t / 4 + j) : 0); // heights are absolute: all above the floor
      row[6 + 3 * j] = 0.1 * Math.sin(t / 5 + j) + (t % 2 ? jitter : -jitter);
    }
    row[4 + 3 * 15] = 0.2; // l_shoulder (joint 16)
    row[4 + 3 * 16] = -0.2; // r_shoulder (joint 17)
  }
  const k = r.known;
  if (k) for (let i = 0; i < f.length; i++) if (k.keep[i] === 1) f[i] = k.features[i];
  return { frames: r.frames, fps: 20, features: f, joints: recoverJoints(f, r.frames) };
}

