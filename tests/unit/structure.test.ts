// The TypeScript tree's shape (issue 31): read with the `typescript` compiler API (parse only, nothing run).
// - no import cycle among src/ and web/ modules (static imports, `export … from` and dynamic import(),
//   type-only imports included: a cycle through types is still two modules that cannot be read apart);
// - no source file over 500 lines (src/ and web/ hold no tests and no generated files);
// - no function (declaration, method, arrow, function expression, constructor, accessor) over 120 lines
//   without a one-line `// long: <reason>` comment directly above it.
// Find the offenders by hand with: npx vitest run tests/unit/structure.test.ts
import { existsSync, readdirSync, readFileSync, statSync } from 'node:fs';
import path from 'node:path';
import ts from 'typescript';
import { describe, expect, it } from 'vitest';

const ROOT = path.resolve(__dirname, '../..');
const MAX_FILE_LINES = 500;
const MAX_FUNCTION_LINES = 120;

function sources(dir: string): string[] {
  return readdirSync(dir).flatMap((name) => {
    const p = path.join(dir, name);
    if (statSync(p).isDirectory()) return sources(p);
    return /\.tsx?$/.test(name) && !name.endsWith('.d.ts') ? [p] : [];
  });
}

const FILES = ['src', 'web'].flatMap((d) => sources(path.join(ROOT, d)));
const rel = (f: string) => path.relative(ROOT, f).split(path.sep).join('/');
const parsed = new Map(FILES.map((f) => [f, ts.createSourceFile(f, readFileSync(f, 'utf8'), ts.ScriptTarget.ES2022, true)]));

/** './x' from `from` → the source file it names ('./x.ts', './x/index.ts'), or undefined (a package). */
export function resolveImport(spec: string, from: string): string | undefined {
  if (!spec.startsWith('./') && !spec.startsWith('../')) return undefined;
  const base = path.resolve(path.dirname(from), spec.replace(/\.js$/, ''));
  return [base, `${base}.ts`, `${base}.tsx`, path.join(base, 'index.ts')].find((p) => parsed.has(p) || (existsSync(p) && statSync(p).isFile()));
}

/** The module specifiers a file imports or re-exports, dynamic import('…') included. */
export function importsOf(sf: ts.SourceFile): string[] {
  const out: string[] = [];
  const visit = (n: ts.Node) => {
    if ((ts.isImportDeclaration(n) || ts.isExportDeclaration(n)) && n.moduleSpecifier && ts.isStringLiteral(n.moduleSpecifier)) out.push(n.moduleSpecifier.text);
    if (ts.isCallExpression(n) && n.expression.kind === ts.SyntaxKind.ImportKeyword && n.arguments[0] && ts.isStringLiteral(n.arguments[0])) out.push(n.arguments[0].text);
    ts.forEachChild(n, visit);
  };
  visit(sf);
  return out;
}

/** Every import cycle of a graph, each as its path of files (first == last), one per strongly connected part. */
export function cyclesOf(graph: Map<string, string[]>): string[][] {
  const cycles: string[][] = [];
  const state = new Map<string, 'open' | 'done'>();
  const stack: string[] = [];
  const visit = (f: string) => {
    state.set(f, 'open');
    stack.push(f);
    for (const g of graph.get(f) ?? []) {
      if (state.get(g) === 'open') cycles.push([...stack.slice(stack.indexOf(g)), g]);
      else if (!state.has(g)) visit(g);
    }
    stack.pop();
    state.set(f, 'done');
  };
  for (const f of [...graph.keys()].sort()) if (!state.has(f)) visit(f);
  return cycles;
}

type FunctionLike = ts.FunctionDeclaration | ts.MethodDeclaration | ts.ArrowFunction | ts.FunctionExpression | ts.ConstructorDeclaration | ts.AccessorDeclaration;
const isFunctionLike = (n: ts.Node): n is FunctionLike =>
  ts.isFunctionDeclaration(n) || ts.isMethodDeclaration(n) || ts.isArrowFunction(n) || ts.isFunctionExpression(n) || ts.isConstructorDeclaration(n) || ts.isAccessor(n);

/** The statement or member a function stands in (an arrow's `const f = …`, a property `f = () => …`). */
function holder(n: ts.Node): ts.Node {
  let h: ts.Node = n;
  while (h.parent && !ts.isSourceFile(h.parent) && !ts.isBlock(h.parent) && !ts.isClassLike(h.parent) && !ts.isModuleBlock(h.parent)) {
    if (ts.isCallExpression(h.parent) || ts.isObjectLiteralExpression(h.parent) || ts.isArrayLiteralExpression(h.parent)) break;
    h = h.parent;
  }
  return h;
}

/** `name (file:line, N lines)` for each function over `max` lines with no `// long: <reason>` right above it. */
export function longFunctions(sf: ts.SourceFile, max = MAX_FUNCTION_LINES): string[] {
  const out: string[] = [];
  const lineOf = (pos: number) => sf.getLineAndCharacterOfPosition(pos).line + 1;
  const visit = (n: ts.Node) => {
    if (isFunctionLike(n) && n.body) {
      const h = holder(n);
      const first = lineOf(n.getStart(sf));
      const lines = lineOf(n.end) - first + 1;
      const above = sf.text.split('\n')[lineOf(h.getStart(sf)) - 2] ?? '';
      if (lines > max && !/^\s*\/\/ long: \S/.test(above)) {
        const name = n.name?.getText(sf) ?? (ts.isVariableDeclaration(n.parent) ? n.parent.name.getText(sf) : '(anonymous)');
        out.push(`${name} (${rel(sf.fileName)}:${first}, ${lines} lines)`);
      }
    }
    ts.forEachChild(n, visit);
  };
  visit(sf);
  return out;
}

describe('structure of src/ and web/ (issue 31)', () => {
  it('has no import cycle among its modules', () => {
    const graph = new Map(FILES.map((f) => [f, importsOf(parsed.get(f)!).map((s) => resolveImport(s, f)).filter((g): g is string => !!g && parsed.has(g))]));
    expect(cyclesOf(graph).map((c) => c.map(rel).join(' → '))).toEqual([]);
  });

  it(`has no source file over ${MAX_FILE_LINES} lines`, () => {
    const over = FILES
      .map((f) => [rel(f), parsed.get(f)!.getLineAndCharacterOfPosition(parsed.get(f)!.end).line + 1] as const)
      .filter(([, n]) => n > MAX_FILE_LINES);
    expect(over.map(([f, n]) => `${f}: ${n} lines`)).toEqual([]);
  });

  it(`has no function over ${MAX_FUNCTION_LINES} lines without a '// long: <reason>' line above it`, () => {
    expect(FILES.flatMap((f) => longFunctions(parsed.get(f)!))).toEqual([]);
  });
});

describe('the structure checks themselves', () => {
  const sf = (text: string) => ts.createSourceFile(path.join(ROOT, 'src/x.ts'), text, ts.ScriptTarget.ES2022, true);
  const body = (n: number) => Array.from({ length: n }, (_, i) => `  const v${i} = ${i};`).join('\n');

  it('finds a cycle of three modules and none in a chain', () => {
    expect(cyclesOf(new Map([['a', ['b']], ['b', ['c']], ['c', ['a']]]))).toEqual([['a', 'b', 'c', 'a']]);
    expect(cyclesOf(new Map([['a', ['b']], ['b', ['c']], ['c', []]]))).toEqual([]);
  });

  it('reads static, type-only, re-export and dynamic imports', () => {
    expect(importsOf(sf(`import a from './a';\nimport type { B } from '../b';\nexport { c } from './c';\nconst d = () => import('./d');`))).toEqual(['./a', '../b', './c', './d']);
  });

  it('flags a long function, an arrow and a method, and passes one with a reason', () => {
    const text = [
      `function f() {\n${body(125)}\n}`,
      `const g = () => {\n${body(125)}\n};`,
      `class K {\n  m() {\n${body(125)}\n  }\n}`,
      `// long: one table, read top to bottom\nfunction h() {\n${body(125)}\n}`,
      `function short() {\n${body(110)}\n}`,
    ].join('\n');
    expect(longFunctions(sf(text)).map((s) => s.split(' ')[0])).toEqual(['f', 'g', 'm']);
  });
});
