// A small evaluator for the subset of GLSL that tone-mapping shader text is
// written in, so that tests/operators/three_vectors.mjs can run the shader
// functions that pinned npm packages ship (three.js's tone-mapping chunk,
// glsl-tone-map's AgX) on the CPU, from the packages' own text, instead of
// from a transcription of ours.
//
// It parses the text (after a minimal preprocessor: comments, #ifndef/#ifdef/
// #else/#endif, object- and function-like #define, #pragma ignored) into a
// tree and interprets it. Arithmetic is JavaScript's: IEEE-754 binary64, not
// the GPU's binary32. Operations are applied exactly in the order the text
// writes them (a * b * c is (a * b) * c); the built-ins follow the GLSL ES
// 3.00 definitions:
//   mat3(9 scalars) and mat3(vec3, vec3, vec3) fill COLUMNS (column-major);
//   mat3 * vec3 is the matrix product, r[i] = (M[0][i]*v[0] + M[1][i]*v[1]) + M[2][i]*v[2]
//   (M[col][row]);
//   mix(x, y, a) = x * (1 - a) + y * a;  clamp(x, lo, hi) = min(max(x, lo), hi);
//   dot(x, y) = (x0*y0 + x1*y1) + x2*y2;  exp2(x) = 2 ** x;  log2 and pow are
//   Math.log2 and Math.pow (V8's fdlibm ports: the same bits on every CPU).
// Where GLSL leaves a result undefined (pow(x, y) with x < 0, or x == 0 and
// y <= 0; log2(x) or log(x) with x <= 0; sqrt(x) with x < 0; division by
// zero; clamp with lo > hi) or a value stops being finite, evaluation throws
// GlslUndefined, so that no NaN or platform guess ends up in a lock file.
//
// Types: bool, int, float, vec3, mat3 (the tone mappers need nothing else).
// Anything outside the subset (another type, a swizzle assignment, a loop,
// out/inout parameters, implicit int-to-float conversion outside a
// constructor, vec3 * mat3, ...) is a parse or evaluation error: the lock
// must fail loudly when a package's text moves past what is evaluated here.

export class GlslError extends Error {}

// An operation whose result GLSL leaves undefined (or a non-finite value).
// `kind` names the rule (stable text, for lock files); the message adds the
// operands.
export class GlslUndefined extends Error {
  constructor(kind, detail) {
    super(`${kind}: ${detail}`);
    this.kind = kind;
  }
}

const TYPES = new Set(['void', 'bool', 'int', 'float', 'vec3', 'mat3']);

// ---------------------------------------------------------------- preprocessor

function stripComments(text) {
  // Keeps newlines so that line-based directives stay on their lines.
  let out = '';
  let i = 0;
  while (i < text.length) {
    if (text.startsWith('//', i)) {
      while (i < text.length && text[i] !== '\n') i++;
    } else if (text.startsWith('/*', i)) {
      const end = text.indexOf('*/', i + 2);
      if (end < 0) throw new GlslError('unterminated /* comment');
      out += text.slice(i, end + 2).replace(/[^\n]/g, ' ');
      i = end + 2;
    } else {
      out += text[i++];
    }
  }
  return out;
}

function preprocess(text, defines) {
  const macros = new Map();
  for (const [name, body] of Object.entries(defines)) {
    macros.set(name, { params: null, body: tokenize(String(body)) });
  }
  const stack = []; // for each open #if: { active, parentActive, seenElse }
  const active = () => stack.every((s) => s.active);
  const kept = [];
  for (const line of stripComments(text).split('\n')) {
    const m = /^\s*#\s*(\w+)\s*(.*)$/.exec(line);
    if (!m) {
      kept.push(active() ? line : '');
      continue;
    }
    const [, directive, rest] = m;
    kept.push('');
    if (directive === 'ifdef' || directive === 'ifndef') {
      const name = rest.trim();
      if (!/^\w+$/.test(name)) throw new GlslError(`#${directive} ${rest}`);
      const defined = macros.has(name);
      stack.push({ active: directive === 'ifdef' ? defined : !defined, seenElse: false });
    } else if (directive === 'else') {
      const top = stack[stack.length - 1];
      if (!top || top.seenElse) throw new GlslError('#else without #if');
      top.active = !top.active;
      top.seenElse = true;
    } else if (directive === 'endif') {
      if (!stack.pop()) throw new GlslError('#endif without #if');
    } else if (!active()) {
      // Directives in a skipped group are not evaluated.
    } else if (directive === 'define') {
      const d = /^(\w+)(\(([^)]*)\))?\s*(.*)$/.exec(rest);
      if (!d) throw new GlslError(`#define ${rest}`);
      const params = d[2] === undefined ? null : d[3].split(',').map((p) => p.trim()).filter(Boolean);
      macros.set(d[1], { params, body: tokenize(d[4]) });
    } else if (directive === 'undef') {
      macros.delete(rest.trim());
    } else if (directive === 'pragma' || directive === 'version' || directive === 'extension') {
      // No effect on the evaluated functions.
    } else {
      throw new GlslError(`unsupported preprocessor directive #${directive}`);
    }
  }
  if (stack.length) throw new GlslError('unterminated #if');
  return expandMacros(tokenize(kept.join('\n')), macros, new Set());
}

function expandMacros(tokens, macros, expanding) {
  const out = [];
  for (let i = 0; i < tokens.length; i++) {
    const t = tokens[i];
    const macro = t.kind === 'ident' && !expanding.has(t.value) ? macros.get(t.value) : undefined;
    if (!macro) {
      out.push(t);
      continue;
    }
    let body = macro.body;
    if (macro.params !== null) {
      if (tokens[i + 1]?.value !== '(') {
        out.push(t);
        continue;
      }
      // Collect the arguments: split at top-level commas.
      const args = [[]];
      let depth = 0;
      let j = i + 2;
      for (; j < tokens.length; j++) {
        const v = tokens[j].value;
        if (v === '(') depth++;
        if (v === ')' && depth-- === 0) break;
        if (v === ',' && depth === 0) args.push([]);
        else args[args.length - 1].push(tokens[j]);
      }
      if (j === tokens.length) throw new GlslError(`unterminated call of macro ${t.value}`);
      if (args.length !== macro.params.length) {
        throw new GlslError(`macro ${t.value} takes ${macro.params.length} arguments`);
      }
      const expandedArgs = args.map((a) => expandMacros(a, macros, expanding));
      body = body.flatMap((b) => {
        const k = b.kind === 'ident' ? macro.params.indexOf(b.value) : -1;
        return k < 0 ? [b] : expandedArgs[k];
      });
      i = j;
    }
    out.push(...expandMacros(body, macros, new Set([...expanding, t.value])));
  }
  return out;
}

// ------------------------------------------------------------------- tokenizer

const PUNCT = ['+=', '-=', '*=', '/=', '<=', '>=', '==', '!=', '&&', '||', '^^', '++', '--',
  '(', ')', '{', '}', '[', ']', ',', ';', '.', '?', ':', '+', '-', '*', '/', '<', '>', '=', '!'];

function tokenize(text) {
  const tokens = [];
  let i = 0;
  while (i < text.length) {
    const c = text[i];
    if (/\s/.test(c)) {
      i++;
      continue;
    }
    const rest = text.slice(i);
    // GLSL float literals: 1.0, 1., .5, 1e-10, 1.5E3, optional f suffix;
    // int literals: decimal digits (hex and octal are outside the subset).
    let m = /^(?:\d+\.\d*|\.\d+)(?:[eE][+-]?\d+)?[fF]?|^\d+[eE][+-]?\d+[fF]?/.exec(rest);
    if (m) {
      tokens.push({ kind: 'float', value: Number(m[0].replace(/[fF]$/, '')), text: m[0] });
      i += m[0].length;
      continue;
    }
    m = /^\d+/.exec(rest);
    if (m) {
      if (/^0\d|^0[xX]/.test(rest)) throw new GlslError(`unsupported int literal ${rest.slice(0, 8)}`);
      tokens.push({ kind: 'int', value: Number(m[0]), text: m[0] });
      i += m[0].length;
      continue;
    }
    m = /^[A-Za-z_]\w*/.exec(rest);
    if (m) {
      tokens.push({ kind: 'ident', value: m[0] });
      i += m[0].length;
      continue;
    }
    const p = PUNCT.find((q) => rest.startsWith(q));
    if (!p) throw new GlslError(`unexpected character ${JSON.stringify(c)}`);
    tokens.push({ kind: 'punct', value: p });
    i += p.length;
  }
  return tokens;
}

// ---------------------------------------------------------------------- parser

class Parser {
  constructor(tokens) {
    this.tokens = tokens;
    this.pos = 0;
  }

  peek(offset = 0) {
    return this.tokens[this.pos + offset];
  }

  at(value, offset = 0) {
    const t = this.peek(offset);
    return t !== undefined && t.kind !== 'float' && t.kind !== 'int' && t.value === value;
  }

  next() {
    const t = this.tokens[this.pos++];
    if (!t) throw new GlslError('unexpected end of source');
    return t;
  }

  expect(value) {
    const t = this.next();
    if (t.value !== value || t.kind === 'float' || t.kind === 'int') {
      throw new GlslError(`expected ${value}, found ${t.text ?? t.value} (${this.context()})`);
    }
    return t;
  }

  ident() {
    const t = this.next();
    if (t.kind !== 'ident') throw new GlslError(`expected a name, found ${t.value} (${this.context()})`);
    return t.value;
  }

  type() {
    const name = this.ident();
    if (!TYPES.has(name)) throw new GlslError(`unsupported type ${name} (${this.context()})`);
    return name;
  }

  context() {
    return this.tokens.slice(Math.max(0, this.pos - 6), this.pos + 4)
      .map((t) => t.text ?? t.value).join(' ');
  }

  program() {
    const globals = []; // in source order: { kind: 'uniform'|'const'|'var', type, name, init }
    const functions = new Map(); // name -> [{ returnType, params, body }]
    while (this.pos < this.tokens.length) {
      if (this.at(';')) {
        this.next();
        continue;
      }
      if (this.at('uniform')) {
        this.next();
        const type = this.type();
        globals.push({ kind: 'uniform', type, name: this.ident() });
        this.expect(';');
        continue;
      }
      const isConst = this.at('const');
      if (isConst) this.next();
      const type = this.type();
      const name = this.ident();
      if (!isConst && this.at('(')) {
        this.next();
        const params = [];
        if (this.at('void') && this.at(')', 1)) this.next();
        while (!this.at(')')) {
          if (this.at('in') || this.at('const')) this.next();
          if (this.at('out') || this.at('inout')) throw new GlslError(`out/inout parameter in ${name}`);
          const ptype = this.type();
          params.push({ type: ptype, name: this.ident() });
          if (!this.at(')')) this.expect(',');
        }
        this.expect(')');
        if (this.at(';')) { // a prototype
          this.next();
          continue;
        }
        const body = this.block();
        if (!functions.has(name)) functions.set(name, []);
        functions.get(name).push({ returnType: type, params, body, name });
        continue;
      }
      this.expect('=');
      globals.push({ kind: isConst ? 'const' : 'var', type, name, init: this.expression() });
      this.expect(';');
    }
    return { globals, functions };
  }

  block() {
    this.expect('{');
    const statements = [];
    while (!this.at('}')) statements.push(this.statement());
    this.expect('}');
    return { kind: 'block', statements };
  }

  statement() {
    if (this.at('{')) return this.block();
    if (this.at('return')) {
      this.next();
      const value = this.at(';') ? null : this.expression();
      this.expect(';');
      return { kind: 'return', value };
    }
    if (this.at('if')) {
      this.next();
      this.expect('(');
      const test = this.expression();
      this.expect(')');
      const then = this.statement();
      let otherwise = null;
      if (this.at('else')) {
        this.next();
        otherwise = this.statement();
      }
      return { kind: 'if', test, then, otherwise };
    }
    for (const word of ['for', 'while', 'do', 'switch', 'discard', 'break', 'continue']) {
      if (this.at(word)) throw new GlslError(`unsupported statement ${word} (${this.context()})`);
    }
    const isConst = this.at('const');
    if (isConst || (this.peek()?.kind === 'ident' && TYPES.has(this.peek().value) &&
        this.peek(1)?.kind === 'ident')) {
      if (isConst) this.next();
      const type = this.type();
      const declarations = [];
      do {
        const name = this.ident();
        let init = null;
        if (this.at('=')) {
          this.next();
          init = this.assignmentExpression();
        }
        if (isConst && !init) throw new GlslError(`const ${name} without a value`);
        declarations.push({ name, init });
      } while (this.at(',') && this.next());
      this.expect(';');
      return { kind: 'declare', type, isConst, declarations };
    }
    const expression = this.expression();
    this.expect(';');
    return { kind: 'expression', expression };
  }

  expression() {
    const e = this.assignmentExpression();
    if (this.at(',')) throw new GlslError(`unsupported comma expression (${this.context()})`);
    return e;
  }

  assignmentExpression() {
    const target = this.conditional();
    for (const op of ['=', '+=', '-=', '*=', '/=']) {
      if (this.at(op)) {
        this.next();
        if (target.kind !== 'name') {
          throw new GlslError(`unsupported assignment target (${this.context()})`);
        }
        return { kind: 'assign', op, name: target.name, value: this.assignmentExpression() };
      }
    }
    return target;
  }

  conditional() {
    const test = this.binary(0);
    if (!this.at('?')) return test;
    this.next();
    const then = this.assignmentExpression();
    this.expect(':');
    const otherwise = this.assignmentExpression();
    return { kind: 'ternary', test, then, otherwise };
  }

  binary(level) {
    const LEVELS = [['||'], ['^^'], ['&&'], ['==', '!='], ['<', '>', '<=', '>='], ['+', '-'], ['*', '/']];
    if (level === LEVELS.length) return this.unary();
    let left = this.binary(level + 1);
    for (;;) {
      const op = LEVELS[level].find((o) => this.at(o));
      if (!op) return left;
      this.next();
      left = { kind: 'binary', op, left, right: this.binary(level + 1) };
    }
  }

  unary() {
    for (const op of ['+', '-', '!']) {
      if (this.at(op)) {
        this.next();
        return { kind: 'unary', op, operand: this.unary() };
      }
    }
    if (this.at('++') || this.at('--')) throw new GlslError(`unsupported ${this.peek().value}`);
    return this.postfix();
  }

  postfix() {
    let e = this.primary();
    for (;;) {
      if (this.at('.')) {
        this.next();
        e = { kind: 'swizzle', operand: e, fields: this.ident() };
      } else if (this.at('[') || this.at('++') || this.at('--')) {
        throw new GlslError(`unsupported ${this.peek().value} (${this.context()})`);
      } else {
        return e;
      }
    }
  }

  primary() {
    const t = this.next();
    if (t.kind === 'float' || t.kind === 'int') return { kind: 'literal', type: t.kind, value: t.value };
    if (t.value === '(') {
      const e = this.expression();
      this.expect(')');
      return e;
    }
    if (t.kind !== 'ident') throw new GlslError(`unexpected ${t.value} (${this.context()})`);
    if (t.value === 'true' || t.value === 'false') {
      return { kind: 'literal', type: 'bool', value: t.value === 'true' };
    }
    if (this.at('(')) {
      this.next();
      const args = [];
      while (!this.at(')')) {
        args.push(this.assignmentExpression());
        if (!this.at(')')) this.expect(',');
      }
      this.expect(')');
      return { kind: 'call', name: t.value, args };
    }
    return { kind: 'name', name: t.value };
  }
}

// ---------------------------------------------------------------------- values

const val = (type, v) => ({ type, v });
const float = (x) => val('float', finite(x));

function finite(x) {
  if (!Number.isFinite(x)) throw new GlslUndefined('a value is not finite', String(x));
  return x;
}

const isScalar = (a) => a.type === 'float';
const isVec = (a) => a.type === 'vec3';

// Applies f per component to float/vec3 arguments (all floats, or vec3s with
// floats broadcast where `broadcast` allows it).
function componentwise(name, args, f, { broadcast = [] } = {}) {
  const vec = args.find(isVec);
  for (const [k, a] of args.entries()) {
    if (a.type === 'float') continue;
    if (a.type !== 'vec3') throw new GlslError(`${name}: argument ${k + 1} is ${a.type}`);
  }
  if (!vec) return float(f(...args.map((a) => a.v)));
  for (const [k, a] of args.entries()) {
    if (a.type === 'float' && !broadcast.includes(k)) {
      throw new GlslError(`${name}: no overload with a float argument ${k + 1} and a vec3`);
    }
  }
  return val('vec3', [0, 1, 2].map((i) => finite(f(...args.map((a) => (isVec(a) ? a.v[i] : a.v))))));
}

function pow(x, y) {
  if (x < 0) throw new GlslUndefined('pow(x, y) with x < 0', `pow(${x}, ${y})`);
  if (x === 0 && y <= 0) throw new GlslUndefined('pow(0, y) with y <= 0', `pow(${x}, ${y})`);
  return Math.pow(x, y);
}

function positive(name, f) {
  return (x) => {
    if (!(x > 0)) throw new GlslUndefined(`${name}(x) with x <= 0`, `${name}(${x})`);
    return f(x);
  };
}

function divide(a, b) {
  if (b === 0) throw new GlslUndefined('division by zero', `${a} / 0`);
  return a / b;
}

const BUILTINS = {
  pow: (a) => componentwise('pow', a, pow),
  log2: (a) => componentwise('log2', a, positive('log2', Math.log2)),
  log: (a) => componentwise('log', a, positive('log', Math.log)),
  exp2: (a) => componentwise('exp2', a, (x) => 2 ** x),
  exp: (a) => componentwise('exp', a, Math.exp),
  sqrt: (a) => componentwise('sqrt', a, (x) => {
    if (x < 0) throw new GlslUndefined('sqrt(x) with x < 0', `sqrt(${x})`);
    return Math.sqrt(x);
  }),
  abs: (a) => componentwise('abs', a, Math.abs),
  // GLSL's min/max with the second argument a float or the same type. None
  // of the inputs can be NaN (evaluation stops at the first non-finite value).
  min: (a) => componentwise('min', a, (x, y) => (y < x ? y : x), { broadcast: [1] }),
  max: (a) => componentwise('max', a, (x, y) => (x < y ? y : x), { broadcast: [1] }),
  clamp: (a) => componentwise('clamp', a, (x, lo, hi) => {
    if (lo > hi) throw new GlslUndefined('clamp(x, lo, hi) with lo > hi', `clamp(${x}, ${lo}, ${hi})`);
    const m = x < lo ? lo : x;
    return hi < m ? hi : m;
  }, { broadcast: [1, 2] }),
  mix: (a) => componentwise('mix', a, (x, y, t) => x * (1 - t) + y * t, { broadcast: [2] }),
  dot: (a) => {
    if (a.length !== 2 || !a.every(isVec)) throw new GlslError('dot: only dot(vec3, vec3)');
    return float(a[0].v[0] * a[1].v[0] + a[0].v[1] * a[1].v[1] + a[0].v[2] * a[1].v[2]);
  },
  float: (a) => {
    if (a.length !== 1 || !['float', 'int', 'bool'].includes(a[0].type)) {
      throw new GlslError('float(): only float(scalar)');
    }
    return float(Number(a[0].v));
  },
  vec3: (a) => {
    const scalars = a.map((x) => (x.type === 'int' ? val('float', x.v) : x));
    if (scalars.length === 1 && isScalar(scalars[0])) return val('vec3', [0, 1, 2].map(() => scalars[0].v));
    if (scalars.length === 1 && isVec(scalars[0])) return val('vec3', [...scalars[0].v]);
    if (scalars.length === 3 && scalars.every(isScalar)) return val('vec3', scalars.map((x) => x.v));
    throw new GlslError(`vec3(${a.map((x) => x.type).join(', ')}) is outside the subset`);
  },
  mat3: (a) => {
    // Column-major, as GLSL: mat3(c0, c1, c2) or mat3(c0.x, c0.y, c0.z, c1.x, ...).
    const scalars = a.map((x) => (x.type === 'int' ? val('float', x.v) : x));
    if (scalars.length === 3 && scalars.every(isVec)) return val('mat3', scalars.map((c) => [...c.v]));
    if (scalars.length === 9 && scalars.every(isScalar)) {
      return val('mat3', [0, 3, 6].map((k) => scalars.slice(k, k + 3).map((x) => x.v)));
    }
    throw new GlslError(`mat3(${a.map((x) => x.type).join(', ')}) is outside the subset`);
  },
};

function arithmetic(op, a, b) {
  const f = { '+': (x, y) => x + y, '-': (x, y) => x - y, '*': (x, y) => x * y, '/': divide }[op];
  if (a.type === 'int' && b.type === 'int') {
    if (op === '/') throw new GlslError('integer division is outside the subset');
    return val('int', f(a.v, b.v));
  }
  if (a.type === 'int' || b.type === 'int') {
    throw new GlslError(`no implicit int conversion in GLSL ES: ${a.type} ${op} ${b.type}`);
  }
  if (op === '*' && a.type === 'mat3') {
    if (b.type !== 'vec3') throw new GlslError(`mat3 * ${b.type} is outside the subset`);
    const [c0, c1, c2] = a.v;
    return val('vec3', [0, 1, 2].map((i) => finite(c0[i] * b.v[0] + c1[i] * b.v[1] + c2[i] * b.v[2])));
  }
  if (a.type === 'mat3' || b.type === 'mat3') throw new GlslError(`${a.type} ${op} ${b.type} is outside the subset`);
  if (a.type === 'bool' || b.type === 'bool') throw new GlslError(`arithmetic on bool`);
  if (isScalar(a) && isScalar(b)) return float(f(a.v, b.v));
  return val('vec3', [0, 1, 2].map((i) => finite(f(isVec(a) ? a.v[i] : a.v, isVec(b) ? b.v[i] : b.v))));
}

function convertible(type, value) {
  // Initialisation and assignment: the same type (GLSL ES has no implicit conversions).
  if (value.type !== type) throw new GlslError(`a ${value.type} assigned to a ${type}`);
  return value;
}

// ------------------------------------------------------------------ interpreter

class Return {
  constructor(value) {
    this.value = value;
  }
}

export class Program {
  // source: GLSL text; uniforms: { name: number } for float uniforms;
  // defines: { NAME: 'value' } as if #define'd before the text.
  constructor(source, { uniforms = {}, defines = {} } = {}) {
    const { globals, functions } = new Parser(preprocess(source, defines)).program();
    this.functions = functions;
    this.globals = new Map();
    for (const g of globals) {
      if (this.globals.has(g.name)) throw new GlslError(`${g.name} declared twice`);
      if (g.kind === 'uniform') {
        if (g.type !== 'float') throw new GlslError(`uniform ${g.type} ${g.name} is outside the subset`);
        // A uniform without a value only fails if something reads it.
        this.globals.set(g.name, { type: g.type, isConst: true, value: g.name in uniforms ? float(uniforms[g.name]) : null });
      } else {
        const value = convertible(g.type, this.evaluate(g.init, [this.globals]));
        this.globals.set(g.name, { type: g.type, isConst: g.kind === 'const', value });
      }
    }
    for (const name of Object.keys(uniforms)) {
      if (!this.globals.has(name)) throw new GlslError(`no uniform ${name} in the source`);
    }
  }

  has(name) {
    return this.functions.has(name);
  }

  // Calls a function of the source with JavaScript numbers (for a float) or
  // 3-arrays (for a vec3); returns the same. Throws GlslUndefined where GLSL
  // leaves the result undefined.
  call(name, ...args) {
    const values = args.map((a) => (Array.isArray(a) ? val('vec3', a.map((x) => finite(Number(x)))) : float(a)));
    const result = this.invoke(name, values);
    return result.type === 'vec3' ? [...result.v] : result.v;
  }

  invoke(name, args) {
    const overloads = this.functions.get(name);
    if (!overloads) {
      if (BUILTINS[name]) return BUILTINS[name](args);
      throw new GlslError(`no function ${name}`);
    }
    const f = overloads.find((o) => o.params.length === args.length &&
      o.params.every((p, k) => p.type === args[k].type));
    if (!f) throw new GlslError(`no ${name}(${args.map((a) => a.type).join(', ')})`);
    const frame = new Map(f.params.map((p, k) => [p.name, { type: p.type, isConst: false, value: args[k] }]));
    const result = this.execute(f.body, [this.globals, frame]);
    if (f.returnType === 'void') return null;
    if (!(result instanceof Return)) throw new GlslError(`${name} ends without a return`);
    return convertible(f.returnType, result.value);
  }

  execute(statement, scopes) {
    switch (statement.kind) {
      case 'block': {
        const inner = [...scopes, new Map()];
        for (const s of statement.statements) {
          const r = this.execute(s, inner);
          if (r instanceof Return) return r;
        }
        return null;
      }
      case 'declare': {
        const scope = scopes[scopes.length - 1];
        for (const d of statement.declarations) {
          if (scope.has(d.name)) throw new GlslError(`${d.name} declared twice`);
          const value = d.init ? convertible(statement.type, this.evaluate(d.init, scopes)) : null;
          scope.set(d.name, { type: statement.type, isConst: statement.isConst, value });
        }
        return null;
      }
      case 'return':
        return new Return(statement.value ? this.evaluate(statement.value, scopes) : null);
      case 'if': {
        const test = this.evaluate(statement.test, scopes);
        if (test.type !== 'bool') throw new GlslError('if on a non-bool');
        const branch = test.v ? statement.then : statement.otherwise;
        return branch ? this.execute(branch, [...scopes, new Map()]) : null;
      }
      case 'expression':
        this.evaluate(statement.expression, scopes);
        return null;
      default:
        throw new GlslError(`statement ${statement.kind}`);
    }
  }

  lookup(name, scopes) {
    for (let k = scopes.length - 1; k >= 0; k--) {
      if (scopes[k].has(name)) return scopes[k].get(name);
    }
    throw new GlslError(`unknown name ${name}`);
  }

  evaluate(e, scopes) {
    switch (e.kind) {
      case 'literal':
        return e.type === 'float' ? float(e.value) : val(e.type, e.value);
      case 'name': {
        const slot = this.lookup(e.name, scopes);
        if (slot.value === null) throw new GlslError(`${e.name} is read before it has a value`);
        return slot.value;
      }
      case 'assign': {
        const slot = this.lookup(e.name, scopes);
        if (slot.isConst) throw new GlslError(`assignment to const or uniform ${e.name}`);
        const rhs = this.evaluate(e.value, scopes);
        const value = e.op === '=' ? rhs : arithmetic(e.op[0], slot.value, rhs);
        slot.value = convertible(slot.type, value);
        return slot.value;
      }
      case 'ternary': {
        const test = this.evaluate(e.test, scopes);
        if (test.type !== 'bool') throw new GlslError('?: on a non-bool');
        const a = this.evaluate(test.v ? e.then : e.otherwise, scopes);
        return a;
      }
      case 'unary': {
        const a = this.evaluate(e.operand, scopes);
        if (e.op === '!') {
          if (a.type !== 'bool') throw new GlslError('! on a non-bool');
          return val('bool', !a.v);
        }
        if (e.op === '+') return a;
        if (a.type === 'vec3') return val('vec3', a.v.map((x) => -x));
        if (a.type === 'float' || a.type === 'int') return val(a.type, -a.v);
        throw new GlslError(`-${a.type}`);
      }
      case 'binary': {
        if (e.op === '&&' || e.op === '||' || e.op === '^^') {
          const a = this.evaluate(e.left, scopes);
          if (a.type !== 'bool') throw new GlslError(`${e.op} on a non-bool`);
          if (e.op === '&&' && !a.v) return a;
          if (e.op === '||' && a.v) return a;
          const b = this.evaluate(e.right, scopes);
          if (b.type !== 'bool') throw new GlslError(`${e.op} on a non-bool`);
          return val('bool', e.op === '^^' ? a.v !== b.v : b.v);
        }
        const a = this.evaluate(e.left, scopes);
        const b = this.evaluate(e.right, scopes);
        if (['<', '>', '<=', '>='].includes(e.op)) {
          if (a.type !== b.type || !['float', 'int'].includes(a.type)) {
            throw new GlslError(`${a.type} ${e.op} ${b.type}`);
          }
          const r = { '<': a.v < b.v, '>': a.v > b.v, '<=': a.v <= b.v, '>=': a.v >= b.v }[e.op];
          return val('bool', r);
        }
        if (e.op === '==' || e.op === '!=') {
          if (a.type !== b.type || a.type === 'mat3') throw new GlslError(`${a.type} ${e.op} ${b.type}`);
          const same = a.type === 'vec3' ? a.v.every((x, i) => x === b.v[i]) : a.v === b.v;
          return val('bool', e.op === '==' ? same : !same);
        }
        return arithmetic(e.op, a, b);
      }
      case 'swizzle': {
        const a = this.evaluate(e.operand, scopes);
        if (a.type !== 'vec3') throw new GlslError(`swizzle of a ${a.type}`);
        const sets = ['xyz', 'rgb', 'stp'];
        const set = sets.find((s) => [...e.fields].every((c) => s.includes(c)));
        if (!set || (e.fields.length !== 1 && e.fields.length !== 3)) {
          throw new GlslError(`swizzle .${e.fields} is outside the subset`);
        }
        const picked = [...e.fields].map((c) => a.v[set.indexOf(c)]);
        return picked.length === 1 ? float(picked[0]) : val('vec3', picked);
      }
      case 'call':
        return this.invoke(e.name, e.args.map((x) => this.evaluate(x, scopes)));
      default:
        throw new GlslError(`expression ${e.kind}`);
    }
  }
}
