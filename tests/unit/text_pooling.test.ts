// Pure pooling helpers used by the MiniLM encoder (mirrors emdm/text/pooling.py).
import { describe, expect, test } from 'vitest';
import { cosine, l2Normalize, meanPool } from '../../src/text';

describe('meanPool / l2Normalize / cosine', () => {
  test('mean over unmasked tokens only', () => {
    const hidden = [1, 0, 3, 4, 100, 100]; // 3 tokens × 2 dims
    expect(Array.from(meanPool(hidden, 3, 2, [1, 1, 0]))).toEqual([2, 2]);
    expect(Array.from(meanPool(hidden, 3, 2, [1n, 1n, 0n]))).toEqual([2, 2]);
    expect(Array.from(meanPool(hidden, 3, 2))).toEqual([104 / 3, 104 / 3].map(Math.fround));
  });
  test('shape mismatch is a clear error', () => {
    expect(() => meanPool([1, 2, 3], 2, 2)).toThrow(/expected tokens\*dim = 2\*2/);
  });
  test('unit length, zero stays zero', () => {
    expect(Array.from(l2Normalize(new Float32Array([3, 4])))).toEqual([0.6, 0.8].map(Math.fround));
    expect(Array.from(l2Normalize(new Float32Array([0, 0])))).toEqual([0, 0]);
  });
  test('cosine', () => {
    expect(cosine([1, 0], [0, 2])).toBe(0);
    expect(cosine([1, 1], [2, 2])).toBeCloseTo(1, 12);
    expect(() => cosine([1], [1, 2])).toThrow(/lengths 1 and 2 differ/);
  });
});
