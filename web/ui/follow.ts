// A camera's follow point for a moving character: it trails the root smoothly (time constant TAU) but
// leads by the root's smoothed velocity × TAU, so at a steady speed it sits on the root instead of
// TAU × speed behind it (1 m behind a 3 m/s run: enough to push the character under the rail's panels in
// the compare view's half-width stage). A jump of the root (loop wrap, seek, scrub) snaps it.
import { Vector3 } from 'three';

const TAU = 1 / 3; // s: how quickly the point catches up (and how far a plain trail lags: TAU × speed)
const VEL_TAU = 0.5; // s: smoothing of the velocity estimate (steps and sways average out)
const HEIGHT = 0.9; // m: the point's height (about the pelvis)

export class RootFollower {
  /** The follow point: where the camera looks. */
  readonly point = new Vector3(0, HEIGHT, 0);
  private readonly last = new Vector3(Number.NaN, 0, 0);
  private readonly velocity = new Vector3();
  private readonly goal = new Vector3();
  private readonly moved = new Vector3();

  /**
   * Advance `dt` seconds towards `root` (x, y, z; y ignored). Returns how far the point moved (a shared
   * vector: copy it to keep it). A jump (more horizontal travel than 0.5 m or 6 m/s × dt, faster than a
   * sprint; or the first root) snaps the point onto the root and forgets the velocity.
   */
  update(root: ArrayLike<number>, dt: number): Vector3 {
    const dx = root[0] - this.last.x;
    const dz = root[2] - this.last.z;
    const jumped = !(Math.hypot(dx, dz) <= Math.max(0.5, 6 * dt)); // NaN (no root before) is a jump
    this.last.set(root[0], 0, root[2]);
    if (jumped) {
      this.velocity.set(0, 0, 0);
      return this.snap(root);
    }
    if (dt > 0) this.velocity.lerp(this.goal.set(dx / dt, 0, dz / dt), 1 - Math.exp(-dt / VEL_TAU));
    this.goal.set(root[0] + this.velocity.x * TAU, HEIGHT, root[2] + this.velocity.z * TAU);
    return this.move(1 - Math.exp(-dt / TAU));
  }

  /** Put the point on the root now. Returns how far it moved (a shared vector). */
  snap(root: ArrayLike<number>): Vector3 {
    this.goal.set(root[0], HEIGHT, root[2]);
    return this.move(1);
  }

  private move(k: number): Vector3 {
    this.moved.copy(this.goal).sub(this.point).multiplyScalar(k);
    this.point.add(this.moved);
    return this.moved;
  }
}
