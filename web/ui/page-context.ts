// The page's parts as one object for its panels (web/main.ts builds it). Its own module, above the
// session and the view it names, so that neither of them imports the panels' side.
import type { Controls } from './controls';
import type { Generation, Session, SessionGenerateOptions } from './session';
import type { PageState } from './state';
import type { View } from './view';

/**
 * What the page hands to every panel (web/main.ts builds it): the session that generates, the view
 * that shows, the side-bar controls, and `generate`, which runs a request as the Generate button does
 * (busy button, progress, status line, caption, URL, errors reported; newest request wins) and shows
 * the result. A new panel takes this in its constructor, e.g. `new TimelinePanel(page)`, and calls
 * `page.generate(state, { extra: { known } })` or `page.view.play(track)`.
 */
export interface PageContext {
  session: Session;
  view: View;
  controls: Controls;
  generate(state: PageState, o?: SessionGenerateOptions): Promise<Generation>;
}
