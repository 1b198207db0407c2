// The page's pure request/URL checks: checkRequest (web/ui/testapi.ts) validates a whole test-API request
// before any control is touched, unknownParamsNotice (web/ui/state.ts) names URL parameters the page ignores.
import { describe, expect, it } from 'vitest';
import { checkRequest, type RequestContext } from '../../web/ui/testapi';
import { defaultState, pageFlagNotices, unknownParamsNotice, type Mode, type StateLimits } from '../../web/ui/state';

const LIMITS: StateLimits = {
  supportedSteps: [1, 2, 4, 10], defaultSteps: 4, defaultGuidance: 2.5, actions: ['walk', 'jump'], fps: 20,
  maxFrames: 196, defaultText: 'a person walks', compareSteps: [1, 2, 4, 10, 50],
};

function ctx(over: Partial<RequestContext> = {}): RequestContext {
  return {
    current: defaultState(LIMITS, 42),
    limits: LIMITS,
    models: { 'emdm-t2m-web': { supportedSteps: [1, 2, 4, 10] }, 'diffusion-t2m-web': { supportedSteps: [10, 50] } },
    compareUnavailable: (mode: Mode) => (mode === 'action' ? 'the diffusion model takes no action' : ''),
    ...over,
  };
}

describe('checkRequest', () => {
  it('a prompt asks for a text motion and an action for an action, whatever mode the page is in', () => {
    const inAction = ctx({ current: { ...defaultState(LIMITS, 1), mode: 'action' } });
    expect(checkRequest({ text: 'a person walks' }, inAction).state).toMatchObject({ mode: 'text', text: 'a person walks' });
    const inText = ctx({ current: { ...defaultState(LIMITS, 1), mode: 'text' } });
    expect(checkRequest({ action: LIMITS.actions[1] }, inText).state).toMatchObject({ mode: 'action', action: LIMITS.actions[1] });
    expect(checkRequest({ seed: 3 }, inAction).state.mode).toBe('action'); // neither: the page's mode
    expect(() => checkRequest({ mode: 'action', text: 'a person walks' }, inText)).toThrow(/text is the prompt of mode 'text', not of mode 'action'/);
    expect(() => checkRequest({ mode: 'random', action: LIMITS.actions[0] }, inText)).toThrow(/action is for mode 'action', not mode 'random'/);
    expect(() => checkRequest({ text: 'a', action: LIMITS.actions[0] }, inText)).toThrow(/give mode 'text' or 'action'/);
  });

  it('fills the fields a request leaves out from the current state', () => {
    const r = checkRequest({ text: 'a person jumps', seed: 7 }, ctx());
    expect(r.state).toEqual({ ...defaultState(LIMITS, 42), text: 'a person jumps', seed: 7 });
    expect(r.adjusted).toEqual([]);
    expect(r.model).toBeUndefined();
    expect(checkRequest(undefined, ctx()).state).toEqual(defaultState(LIMITS, 42));
  });

  it.each([
    [{ seed: NaN }, /seed must be a finite number, not NaN/],
    [{ seed: -1 }, /seed must be a whole number 0–4294967295, not -1/],
    [{ seed: 1.5 }, /seed must be a whole number/],
    [{ seed: 2 ** 32 }, /seed must be a whole number/],
    [{ seed: '7' }, /seed must be a finite number, not '7'/],
    [{ guidance: NaN }, /guidance must be a finite number, not NaN/],
    [{ guidance: Infinity }, /guidance must be a finite number, not Infinity/],
    [{ seconds: -1 }, /seconds must be more than 0, not -1/],
    [{ seconds: 0 }, /seconds must be more than 0/],
    [{ seconds: Infinity }, /seconds must be a finite number/],
    [{ seconds: NaN }, /seconds must be a finite number/],
    [{ steps: 3 }, /steps 3 is not one of 1, 2, 4, 10/],
    [{ steps: NaN }, /steps must be a finite number/],
    [{ mode: 'dance' }, /mode 'dance' is not text, action or random/],
    [{ action: 'fly' }, /unknown action 'fly' \(actions: walk, jump\)/],
    [{ text: 5 }, /text must be a string, not 5/],
    [{ compare: 'yes' }, /compare must be true or false/],
    [{ length: 4 }, /unknown field 'length' \(known: mode, text, action, steps, seconds, guidance, seed, compare, model\)/],
    [{ model: 'nope' }, /no model 'nope' in the manifest \(models: emdm-t2m-web, diffusion-t2m-web\)/],
    [{ model: 'diffusion-t2m-web', compare: true }, /either model or compare/],
    [{ model: 'diffusion-t2m-web', steps: 4 }, /steps 4 is not one of diffusion-t2m-web's 10, 50/],
    [{ mode: 'action', compare: true }, /compare view unavailable: the diffusion model takes no action/],
    ['text', /must be an object/],
    [[1], /must be an object/],
  ])('rejects %j with a message naming the field', (req, message) => {
    expect(() => checkRequest(req, ctx())).toThrow(message);
    expect(() => checkRequest(req, ctx())).toThrow(/^window\.emdm\.generate: /);
  });

  it('rejects the whole request when one field is bad (valid fields before it change nothing)', () => {
    const current = defaultState(LIMITS, 42);
    const c = ctx({ current });
    expect(() => checkRequest({ text: 'a person runs', seconds: 3, guidance: NaN }, c)).toThrow(/guidance/);
    expect(current).toEqual(defaultState(LIMITS, 42));
  });

  it('clamps finite seconds and guidance outside the sliders, and says what it changed', () => {
    const r = checkRequest({ seconds: 1e9, guidance: 10 }, ctx());
    expect(r.state.seconds).toBe(9.8);
    expect(r.state.guidance).toBe(6);
    expect(r.adjusted).toEqual(['seconds 1000000000 → 9.8 (1–9.8 s)', 'guidance 10 → 6 (1–6)']);
    const low = checkRequest({ seconds: 0.2, guidance: 0.5 }, ctx());
    expect(low.state.seconds).toBe(1);
    expect(low.state.guidance).toBe(1);
    expect(checkRequest({ seconds: 2.33 }, ctx()).state.seconds).toBe(2.35); // one 20 fps frame is 0.05 s
    expect(checkRequest({ seconds: 2.33 }, ctx()).adjusted).toEqual([]);
  });

  it('compare takes the merged step counts; a named model its own and never compares', () => {
    expect(checkRequest({ compare: true, steps: 50 }, ctx()).state).toMatchObject({ compare: true, steps: 50 });
    expect(() => checkRequest({ steps: 50 }, ctx())).toThrow(/steps 50 is not one of 1, 2, 4, 10/);
    const m = checkRequest({ model: 'diffusion-t2m-web', steps: 50 }, ctx({ current: { ...defaultState(LIMITS, 1), compare: true } }));
    expect(m.model).toBe('diffusion-t2m-web');
    expect(m.state.compare).toBe(false);
  });
});

describe('unknownParamsNotice', () => {
  it('names unknown parameters and the known ones', () => {
    const n = unknownParamsNotice('?mode=text&length=4&text=hi');
    expect(n).toMatch(/'length' is not known and ignored/);
    expect(n).toMatch(/known: mode, text, action, steps, seconds, guidance, seed, backend, compare, noauto, quality/);
    expect(n).toMatch(/length is 'seconds'/);
    expect(unknownParamsNotice('?foo=1&bar=2&foo=3')).toMatch(/parameters 'foo', 'bar' are not known/);
  });

  it('says nothing when every parameter is known', () => {
    expect(unknownParamsNotice('?mode=text&text=a&steps=4&seconds=2&guidance=2&seed=1&backend=wasm&compare=0&noauto=1&quality=high')).toBe('');
    expect(unknownParamsNotice('')).toBe('');
  });
});

describe('pageFlagNotices', () => {
  it("names a quality other than 'high' or 'low'", () => {
    expect(pageFlagNotices('?quality=medium')).toEqual(["URL quality='medium' is not 'high' or 'low'; the page lowers its resolution when frames are slow."]);
    expect(pageFlagNotices('?quality=high&noauto=1')).toEqual([]);
    expect(pageFlagNotices('?quality=low')).toEqual([]);
  });
});
