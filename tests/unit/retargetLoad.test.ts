// Loading users' characters (src/character/retarget/load.ts): bad files get a typed error that says what
// is wrong; nothing outside the given files is fetched; .gltf + .bin + images are packed into one GLB.
import { describe, expect, it } from 'vitest';
import { CharacterLoadError, type CharacterFile, MAX_CHARACTER_BYTES, loadCharacter, packDocument, readGlb } from '../../src/character/retarget/load';
import { writeGlb } from '../../src/export/glb';
import { MAX_BONES, MAX_JSON_BYTES, MAX_NODES } from '../../src/character/retarget/check';
import { mappingToJSON, mappingFromJSON } from '../../src/character/retarget/mapping';
import { manifestSkeleton } from './coreFixtures';
import { RIGS, buildRigGlb } from './retargetRigs';

const sk = manifestSkeleton();
const mixamo = buildRigGlb(sk, RIGS[0]);

async function reason(files: CharacterFile[], opts = {}): Promise<[string, string]> {
  try {
    await loadCharacter(files, opts);
  } catch (e) {
    expect(e).toBeInstanceOf(CharacterLoadError);
    return [(e as CharacterLoadError).reason, (e as Error).message];
  }
  throw new Error('loaded without an error');
}

/** The rig's document with `edit` applied, as a GLB. */
function edited(edit: (json: Record<string, any>) => void): Uint8Array {
  const { json, bin } = readGlb(mixamo, 'x');
  edit(json);
  return writeGlb(json, bin!);
}

describe('loading a character', () => {
  it('reads a GLB: bones, automatic map, node indices, load time', async () => {
    const ch = await loadCharacter([{ name: 'hero.glb', data: mixamo }]);
    expect(ch.name).toBe('hero.glb');
    expect(ch.bones.length).toBeGreaterThan(50); // 22 + fingers + ends
    expect(ch.mapping.pelvis).toBe('mixamorigHips'); // three's loader drops ':' from names
    expect(ch.unmapped).toEqual([]);
    expect(ch.vrm).toBeNull();
    expect(ch.nodeIndex.get(ch.bones[0])).toBeTypeOf('number');
    expect(ch.loadMs).toBeGreaterThan(0);
    // restPose() undoes any posing (retargetMotion reads the rest pose from the scene)
    const hips = ch.bones.find((b) => b.name === 'mixamorigHips')!;
    const q = hips.quaternion.clone();
    const knee = ch.bones.find((b) => b.name === 'mixamorigLeftLeg')!;
    const kq = knee.quaternion.clone();
    const kp = knee.position.clone();
    hips.quaternion.set(0, 1, 0, 0);
    knee.position.x += 1;
    ch.restPose();
    expect(hips.quaternion.equals(q)).toBe(true);
    expect(knee.quaternion.equals(kq)).toBe(true);
    expect(knee.position.equals(kp)).toBe(true);
  });

  it('refuses what is too large, corrupt, compressed, unskinned or not a humanoid, saying so', async () => {
    expect(await reason([{ name: 'a.txt', data: new Uint8Array(4) }])).toEqual(['no-file', expect.stringMatching(/no \.glb, \.gltf or \.vrm/)]);
    expect(await reason([{ name: 'big.glb', data: mixamo }], { maxBytes: 1000 })).toEqual(['too-large', expect.stringMatching(/big\.glb: 0\.0 MB given; characters up to 0 MB/)]);
    // the page's limit: over 100 MB in all (the files of a .gltf counted together) is refused before any parsing
    expect(await reason([{ name: 'huge.gltf', data: new Uint8Array(8) }, { name: 'huge.bin', data: new Uint8Array(MAX_CHARACTER_BYTES) }])).toEqual(['too-large', expect.stringMatching(/huge\.gltf: 100\.0 MB given; characters up to 100 MB are read/)]);
    expect((await reason([{ name: 'cut.glb', data: mixamo.slice(0, 200) }]))[1]).toMatch(/cut\.glb: not a valid binary glTF: the header says \d+ bytes, the file has 200/);
    expect(await reason([{ name: 'junk.vrm', data: new TextEncoder().encode('hello, I am not a model') }])).toEqual(['corrupt', expect.stringMatching(/junk\.vrm: not a valid binary glTF: it does not start with 'glTF'/)]);
    expect(await reason([{ name: 'junk.gltf', data: new TextEncoder().encode('hello, I am not a model') }])).toEqual(['corrupt', expect.stringMatching(/its glTF JSON does not parse/)]);
    expect((await reason([{ name: 'old.gltf', data: new TextEncoder().encode('{"asset":{"version":"1.0"}}') }]))[1]).toMatch(/glTF version '1\.0', only glTF 2\.0/);
    expect((await reason([{ name: 'views.glb', data: edited((j) => (j.bufferViews[0].byteLength = 1e9)) }]))).toEqual(['corrupt', expect.stringMatching(/bufferView 0 lies outside its buffer/)]);
    expect(await reason([{ name: 'draco.glb', data: edited((j) => (j.extensionsRequired = ['KHR_draco_mesh_compression'])) }])).toEqual(['unsupported', expect.stringMatching(/Draco.*export it without/)]);
    expect(await reason([{ name: 'statue.glb', data: edited((j) => delete j.nodes.find((n: any) => n.skin !== undefined).skin) }])).toEqual(['no-skin', expect.stringMatching(/no skinned mesh/)]);
    // a snake: five bones in a row, nothing humanoid about the names
    const snake = edited((j) => j.nodes.forEach((n: any, i: number) => (n.name = `segment${i}`)));
    const [r, msg] = await reason([{ name: 'snake.glb', data: snake }]);
    expect(r).toBe('not-humanoid');
    expect(msg).toMatch(/only 0 of our 22 joints were recognised among its \d+ bones: .*pelvis, l_hip/);
  });

  it('a not-humanoid error carries the bones, and a hand-made map (saved JSON) makes it load', async () => {
    const renamed = edited((j) => j.nodes.forEach((n: any, i: number) => (n.name = `segment${i}`)));
    let err: CharacterLoadError | null = null;
    try {
      await loadCharacter([{ name: 'odd.glb', data: renamed }]);
    } catch (e) {
      err = e as CharacterLoadError;
    }
    expect(err?.bones?.length).toBeGreaterThan(22);
    // the user maps each joint to the node that played it in the original file
    const orig = await loadCharacter([{ name: 'hero.glb', data: mixamo }]);
    const byIndex = new Map([...orig.nodeIndex].map(([o, i]) => [o.name, i]));
    const map = Object.fromEntries(Object.entries(orig.mapping).map(([j, name]) => [j, `segment${byIndex.get(name!)}`]));
    const ch = await loadCharacter([{ name: 'odd.glb', data: renamed }], { mapping: mappingFromJSON(mappingToJSON(map)) });
    expect(ch.mappingSource).toBe('user');
    expect(ch.unmapped).toEqual([]);
    // a saved map that no longer fits says so
    const [r, msg] = await reason([{ name: 'odd.glb', data: renamed }], { mapping: { ...map, head: 'nothing' } });
    expect(r).toBe('not-humanoid');
    expect(msg).toMatch(/the saved bone map does not fit: bone map: head → 'nothing': the character has no bone of that name/);
  });

  it('.gltf with its .bin: packed from the given files; remote and missing URIs are refused, nothing fetched', async () => {
    const { json, bin } = readGlb(mixamo, 'x');
    const gltf = (uri: string) => new TextEncoder().encode(JSON.stringify({ ...json, buffers: [{ ...json.buffers[0], uri }] }));
    const ch = await loadCharacter([{ name: 'rig.gltf', data: gltf('rig%20data.bin') }, { name: 'rig data.bin', data: bin! }]);
    expect(ch.unmapped).toEqual([]);
    expect(ch.json.buffers).toEqual([{ byteLength: ch.bin.byteLength }]);
    expect(await reason([{ name: 'rig.gltf', data: gltf('https://example.com/rig.bin') }])).toEqual(['external-resource', expect.stringMatching(/buffer 0 points to 'https:\/\/example\.com\/rig\.bin': nothing is fetched/)]);
    expect(await reason([{ name: 'rig.gltf', data: gltf('/etc/rig.bin') }])).toEqual(['external-resource', expect.any(String)]);
    expect(await reason([{ name: 'rig.gltf', data: gltf('../rig.bin') }, { name: 'rig.bin', data: bin! }])).toEqual(['external-resource', expect.stringMatching(/not among the files given/)]);
    expect(await reason([{ name: 'rig.gltf', data: gltf('rig.bin') }])).toEqual(['external-resource', expect.stringMatching(/refers to 'rig\.bin', which is not among the files given; drop it together with rig\.gltf/)]);
    // an image by URI: packed into the BIN chunk (the loader never sees a URI)
    const png = new Uint8Array([137, 80, 78, 71, 13, 10, 26, 10]);
    const withImage = { ...json, buffers: [{ ...json.buffers[0], uri: 'rig.bin' }], images: [{ uri: 'skin.png' }] };
    const packed = await loadCharacter([{ name: 'rig.gltf', data: new TextEncoder().encode(JSON.stringify(withImage)) }, { name: 'rig.bin', data: bin! }, { name: 'skin.png', data: png }], { textures: false });
    const img = packed.json.images[0];
    expect(img.uri).toBeUndefined();
    expect(img.mimeType).toBe('image/png');
    const view = packed.json.bufferViews[img.bufferView];
    expect(Array.from(packed.bin.subarray(view.byteOffset, view.byteOffset + view.byteLength))).toEqual(Array.from(png));
    expect(await reason([{ name: 'rig.gltf', data: new TextEncoder().encode(JSON.stringify({ ...withImage, images: [{ uri: 'http://x/skin.png' }] })) }, { name: 'rig.bin', data: bin! }])).toEqual(['external-resource', expect.stringMatching(/image 0 points to 'http:\/\/x\/skin\.png'/)]);
  });

  it('refuses a script or any other scheme as a URI, and a VRM extension three-vrm cannot read', async () => {
    const { json, bin } = readGlb(mixamo, 'x');
    const gltf = (uri: string) => new TextEncoder().encode(JSON.stringify({ ...json, buffers: [{ ...json.buffers[0], uri }] }));
    for (const uri of ['javascript:alert(1)', 'file:///etc/passwd', 'blob:https://x/1', '\\\\server\\share\\rig.bin']) {
      expect(await reason([{ name: 'rig.gltf', data: gltf(uri) }, { name: 'rig.bin', data: bin! }])).toEqual(['external-resource', expect.stringMatching(/nothing is fetched|not among the files given/)]);
    }
    // a VRM 1.0 humanoid of an unknown spec version: three-vrm reads no VRM from it; said, not guessed
    const v1 = readGlb(buildRigGlb(sk, RIGS[2]), 'a.vrm');
    v1.json.extensions.VRMC_vrm.specVersion = '9.9';
    expect(await reason([{ name: 'future.vrm', data: writeGlb(v1.json, v1.bin!) }])).toEqual(['unsupported', expect.stringMatching(/future\.vrm: it declares a VRM extension \(VRMC_vrm 9\.9\) that three-vrm could not read as a humanoid/)]);
  });

  it('reads the VRM humanoid of VRM 1.0 and 0.x files', async () => {
    const v1 = await loadCharacter([{ name: 'a.vrm', data: buildRigGlb(sk, RIGS[2]) }]);
    expect([v1.vrm, v1.mappingSource]).toEqual(['1.0', 'vrm']);
    const v0 = await loadCharacter([{ name: 'b.vrm', data: buildRigGlb(sk, RIGS[3]) }]);
    expect([v0.vrm, v0.mappingSource, v0.unmapped]).toEqual(['0.x', 'vrm', []]);
  });

  it('refuses a rig that could never move (1e308, NaN-free but huge, or scaled to nothing), naming the node', async () => {
    const [r, msg] = await reason([{ name: 'far.glb', data: edited((j) => (j.nodes[2].translation = [1e308, 0, 0])) }]);
    expect(r).toBe('bad-rig');
    expect(msg).toMatch(/far\.glb: node 2 \('[^']*'\) translation holds 1e\+308; every value must be a finite number within ±1e\+6/);
    expect(await reason([{ name: 's.glb', data: edited((j) => (j.nodes[1].scale = [1, 'x', 1])) }])).toEqual(['bad-rig', expect.stringMatching(/node 1 .*scale holds x/)]);
    expect(await reason([{ name: 'm.glb', data: edited((j) => (j.nodes[1].matrix = [1, 0])) }])).toEqual(['bad-rig', expect.stringMatching(/node 1 .*matrix must be a list of 16 numbers/)]);
    // each scale is allowed, their product along the chain is not
    expect(await reason([{ name: 'grow.glb', data: edited((j) => j.nodes.forEach((n: any) => (n.scale = [1000, 1000, 1000]))) }])).toEqual(['bad-rig', expect.stringMatching(/bone '[^']+' lies at \(.*\) at rest/)]);
    expect(await reason([{ name: 'flat.glb', data: edited((j) => j.nodes.forEach((n: any) => (n.scale = [0, 0, 0]))) }])).toEqual(['bad-rig', expect.stringMatching(/mapped bones all lie at one point/)]);
  });

  it('refuses a document of more nodes, bones or JSON than a character has, before building it', async () => {
    const many = (count: number) => edited((j) => {
      for (let i = j.nodes.length; i < count; i++) j.nodes.push({ name: `extra${i}` });
    });
    expect(await reason([{ name: 'crowd.glb', data: many(MAX_NODES + 1) }])).toEqual(['too-complex', expect.stringMatching(`crowd.glb: it has ${MAX_NODES + 1} nodes; characters of up to ${MAX_NODES} nodes are read`)]);
    const bones = edited((j) => {
      for (let i = j.nodes.length; i < MAX_BONES + 1; i++) j.nodes.push({ name: `b${i}` });
      j.skins[0].joints = Array.from({ length: MAX_BONES + 1 }, (_, i) => i);
    });
    expect(await reason([{ name: 'bony.glb', data: bones }])).toEqual(['too-complex', expect.stringMatching(`its skins have ${MAX_BONES + 1} bones`)]);
    const big = new Uint8Array(MAX_JSON_BYTES + 1).fill(0x20);
    expect(await reason([{ name: 'big.gltf', data: big }])).toEqual(['too-large', expect.stringMatching(/big\.gltf: its glTF JSON is 16\.0 MB; up to 16 MB is read/)]);
  });

  it('decodes a large base64 data: URI in slices (the event loop turns meanwhile), byte for byte', async () => {
    const bytes = new Uint8Array(9 * 1024 * 1024 + 5).map((_, i) => (i * 2654435761) >>> 24);
    const b64 = Buffer.from(bytes).toString('base64');
    const wrapped = b64.replace(/(.{76})/g, '$1\n'); // MIME-style line breaks, which atob skips
    for (const text of [b64, wrapped]) {
      let turns = 0;
      let on = true;
      const tick = () => {
        turns++;
        if (on) setImmediate(tick);
      };
      setImmediate(tick);
      const doc = { asset: { version: '2.0' }, buffers: [{ byteLength: bytes.length, uri: `data:application/octet-stream;base64,${text}` }] };
      const packed = await packDocument(doc, null, 'big.gltf', () => null);
      on = false;
      expect(turns).toBeGreaterThanOrEqual(8);
      expect(Buffer.from(packed.bin.subarray(0, bytes.length)).equals(Buffer.from(bytes))).toBe(true); // (toEqual walks 9 M entries for minutes)
      expect(doc.buffers[0].uri.startsWith('data:')).toBe(true); // the caller's document is not changed
    }
    await expect(packDocument({ buffers: [{ byteLength: 3, uri: 'data:;base64,AB%D' }] }, null, 'x.gltf', () => null)).rejects.toThrow(/undecodable data: URI/);
  });
});
