// The playback bar: play/pause (also the space bar), scrubber, time, speed.
import type { MotionPlayer } from '../../src/three';
import { byId } from './dom';

export class PlaybackBar {
  private readonly play = byId('play', HTMLButtonElement);
  private readonly scrub = byId('scrub', HTMLInputElement);
  private readonly time = byId('time');
  private readonly speed = byId('speed', HTMLSelectElement);
  private dragging = false;

  constructor(private readonly player: MotionPlayer) {
    this.play.addEventListener('click', () => this.toggle());
    this.scrub.addEventListener('pointerdown', () => (this.dragging = true));
    window.addEventListener('pointerup', () => (this.dragging = false));
    this.scrub.addEventListener('input', () => this.player.seek(Number(this.scrub.value) * this.player.duration));
    this.speed.addEventListener('change', () => (this.player.speed = Number(this.speed.value)));
    window.addEventListener('keydown', (e) => {
      const t = e.target as HTMLElement | null;
      if (e.code !== 'Space' || (t && /^(TEXTAREA|INPUT|SELECT|BUTTON)$/.test(t.tagName))) return;
      e.preventDefault();
      this.toggle();
    });
    this.sync();
  }

  toggle(): void {
    if (!this.player.track) return; // nothing to play yet
    this.player.playing = !this.player.playing;
    if (this.player.playing && this.player.time >= this.player.duration) this.player.seek(0);
    this.sync();
  }

  /** Reflect the player's clock (call once per displayed frame). */
  sync(): void {
    const p = this.player;
    // no motion yet: a disabled play button and no clock (not a pause icon over "0.0 / 0.0 s")
    const empty = !p.track;
    this.play.disabled = empty;
    this.scrub.disabled = empty;
    this.play.classList.toggle('paused', empty || !p.playing);
    this.play.setAttribute('aria-label', empty ? 'Play (no motion yet)' : p.playing ? 'Pause' : 'Play');
    if (empty) {
      this.scrub.value = '0';
      this.time.textContent = '– / – s';
      return;
    }
    const d = p.duration;
    if (!this.dragging) this.scrub.value = String(d > 0 ? p.time / d : 0);
    this.time.textContent = `${p.time.toFixed(1)} / ${d.toFixed(1)} s`;
    // what a screen reader says of the scrubber: the time, not the fraction (0.593)
    const said = `${p.time.toFixed(1)} of ${d.toFixed(1)} seconds`;
    if (this.scrub.getAttribute('aria-valuetext') !== said) this.scrub.setAttribute('aria-valuetext', said);
  }
}
