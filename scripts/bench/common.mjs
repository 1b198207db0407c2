// What the Node benchmarks share: the repository root, their command-line options and the library's TypeScript
// modules loaded through Vite's SSR loader (the same code the page bundles).
import path from 'node:path';
import { fileURLToPath } from 'node:url';

export const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');

/** `--name value` options and `--name` flags of `args`; `list('a,b')` splits a comma-separated value. */
export function cli(args = process.argv.slice(2)) {
  const opt = (name, dflt) => {
    const i = args.indexOf(`--${name}`);
    return i >= 0 ? args[i + 1] : dflt;
  };
  const flag = (name) => args.includes(`--${name}`);
  const list = (s) => s.split(',').filter(Boolean);
  return { args, opt, flag, list };
}

/** Run `fn(load)` with a middleware-mode Vite server; `load('src/x.ts')` is that module; the server is closed after. */
export async function withLibrary(fn) {
  const { createServer } = await import('vite');
  const server = await createServer({ configFile: path.join(ROOT, 'vite.config.ts'), server: { middlewareMode: true, hmr: false, ws: false }, appType: 'custom', logLevel: 'error' });
  try {
    return await fn((file) => server.ssrLoadModule(path.join(ROOT, file)));
  } finally {
    await server.close();
  }
}
