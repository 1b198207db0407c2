/**
 * The binary glTF container (.glb, glTF 2.0 §4.4): a 12-byte header, a JSON chunk padded with spaces and an
 * optional BIN chunk padded with zeros. Written for the download of a user's character, which keeps its
 * document as it is (export/characterGlb.ts), and for loadCharacter, which hands three's GLTFLoader one
 * packed GLB (character/retarget/load.ts, which also reads the chunks back: readGlb).
 */

/** The glTF JSON, loosely typed (only what we read or rewrite). */
// eslint-disable-next-line @typescript-eslint/no-explicit-any
export type GltfJson = Record<string, any>;

/** 'glTF', the first four bytes of every GLB */
export const GLB_MAGIC = 0x46546c67;
/** chunk types: 'JSON' and 'BIN\0' */
export const CHUNK_JSON = 0x4e4f534a;
export const CHUNK_BIN = 0x004e4942;

/** A binary glTF of a JSON document and its BIN buffer. */
export function writeGlb(json: GltfJson, bin: Uint8Array): Uint8Array {
  const text = new TextEncoder().encode(JSON.stringify(json));
  const jsonLen = Math.ceil(text.byteLength / 4) * 4;
  const binLen = Math.ceil(bin.byteLength / 4) * 4;
  const total = 12 + 8 + jsonLen + (binLen ? 8 + binLen : 0);
  const out = new Uint8Array(total);
  const dv = new DataView(out.buffer);
  dv.setUint32(0, GLB_MAGIC, true);
  dv.setUint32(4, 2, true);
  dv.setUint32(8, total, true);
  dv.setUint32(12, jsonLen, true);
  dv.setUint32(16, CHUNK_JSON, true);
  out.set(text, 20);
  out.fill(0x20, 20 + text.byteLength, 20 + jsonLen);
  if (binLen) {
    dv.setUint32(20 + jsonLen, binLen, true);
    dv.setUint32(24 + jsonLen, CHUNK_BIN, true);
    out.set(bin, 28 + jsonLen);
  }
  return out;
}
