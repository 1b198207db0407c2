// Build the npm package's code: src/ → dist-lib/ (git-ignored) as ES2022 JavaScript with .d.ts, runnable by
// plain Node and by any bundler. `npm run build:lib`; `npm pack` runs it first (prepack).
//
// tsc emits the sources' import specifiers as written ('./manifest', './text'), which bundlers resolve and
// Node's ESM loader does not: every relative specifier in the output gets its file ('./manifest.js',
// './text/index.js'). The generation worker is started as new URL('./generation.worker.ts', import.meta.url)
// (what Vite finds in the sources); in the output it is the .js file beside it.
import { execFileSync } from 'node:child_process';
import { existsSync, readdirSync, readFileSync, rmSync, statSync, writeFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const OUT = path.join(ROOT, 'dist-lib');
const WORKER = 'generation.worker';

/** Every file under dir (recursively). */
function walk(dir) {
  return readdirSync(dir).flatMap((name) => {
    const p = path.join(dir, name);
    return statSync(p).isDirectory() ? walk(p) : [p];
  });
}

/** './x' → './x.js' or './x/index.js', whichever the output has; anything else as it is. */
export function withExtension(spec, fromFile) {
  if (!spec.startsWith('./') && !spec.startsWith('../')) return spec;
  if (/\.(m?js|json)$/.test(spec)) return spec;
  const base = path.resolve(path.dirname(fromFile), spec);
  if (existsSync(base + '.js')) return spec + '.js';
  if (existsSync(path.join(base, 'index.js'))) return spec + '/index.js';
  throw new Error(`${path.relative(ROOT, fromFile)}: cannot resolve '${spec}' in dist-lib`);
}

const SPECIFIER = /(\bfrom\s*|\bimport\s*\(\s*|\bimport\s+)(['"])(\.{1,2}\/[^'"]*)\2/g;

export function rewrite(text, file) {
  const out = text.replace(SPECIFIER, (_m, lead, q, spec) => `${lead}${q}${withExtension(spec, file)}${q}`);
  return out.replaceAll(`'./${WORKER}.ts'`, `'./${WORKER}.js'`);
}

function main() {
  rmSync(OUT, { recursive: true, force: true });
  const tsc = createRequire(import.meta.url).resolve('typescript/bin/tsc');
  execFileSync(process.execPath, [tsc, '-p', path.join(ROOT, 'tsconfig.build.json')], { stdio: 'inherit', cwd: ROOT });
  const files = walk(OUT).filter((f) => f.endsWith('.js') || f.endsWith('.d.ts'));
  for (const f of files) writeFileSync(f, rewrite(readFileSync(f, 'utf8'), f));
  const worker = readFileSync(path.join(OUT, 'worker', 'client.js'), 'utf8');
  if (!worker.includes(`'./${WORKER}.js'`)) throw new Error(`dist-lib/worker/client.js: no './${WORKER}.js' worker URL`);
  console.log(`build-lib: ${files.length} files in ${path.relative(ROOT, OUT)}/`);
}

if (process.argv[1] && path.resolve(process.argv[1]) === fileURLToPath(import.meta.url)) main();
