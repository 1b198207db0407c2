// Load a .glb with three.js's GLTFLoader (as an app would), play its animation and print, as JSON, what a user
// would see: bone names, the skinned mesh's skeleton size, the clip's duration and tracks, and every bone's world
// position at each requested frame. Used by tests/python/test_glb_writer.py.
//   node tests/python/gltf_check.mjs FILE.glb FPS FRAME [FRAME ...]
import { readFileSync } from 'node:fs';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

const [file, fpsArg, ...frameArgs] = process.argv.slice(2);
const bytes = readFileSync(file);
const gltf = await new GLTFLoader().parseAsync(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.length), '');
let skinned = null;
gltf.scene.traverse((o) => { if (o.isSkinnedMesh) skinned = o; });
if (!skinned) throw new Error(`${file}: no SkinnedMesh`);
const bones = skinned.skeleton.bones;
const clip = gltf.animations[0];
const mixer = new THREE.AnimationMixer(gltf.scene);
mixer.clipAction(clip).play();
const poses = [];
for (const f of frameArgs.map(Number)) {
  mixer.setTime(f / Number(fpsArg));
  gltf.scene.updateMatrixWorld(true);
  poses.push(bones.map((b) => b.getWorldPosition(new THREE.Vector3()).toArray()));
}
console.log(JSON.stringify({
  bones: bones.map((b) => b.name),
  animations: gltf.animations.length,
  duration: clip.duration,
  tracks: clip.tracks.map((t) => t.name),
  poses,
}));
