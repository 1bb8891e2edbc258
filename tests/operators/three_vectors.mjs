#!/usr/bin/env node
// Runs the tone-mapping shader functions that the pinned npm packages ship
// (package.json, package-lock.json; installed by `npm ci` in this folder) on
// linear Rec.709 RGB triplets, for tests/operators/make_vectors.py.
//
//   node tests/operators/three_vectors.mjs < {"inputs": [[r, g, b], ...]}
//
// prints {"three": {...}, "glsl_tone_map": {...}} with one output triplet per
// input (null where GLSL leaves the result undefined; "undefined" says why).
//
// What is evaluated is each package's own GLSL text, taken at run time from
// the installed package, by glsl_subset.mjs (a GLSL-subset interpreter in
// binary64: see its header for the exact semantics of each built-in). Nothing
// here restates a constant or a step of an operator.
//
// three.js (npm `three`): ShaderChunk.tonemapping_pars_fragment, the text its
// WebGLRenderer compiles into every fragment shader that tone-maps
// (src/renderers/shaders/ShaderChunk/tonemapping_pars_fragment.glsl.js). The
// renderer's WebGLProgram defines `vec3 toneMapping(vec3 color) { return
// <Name>ToneMapping(color); }` and calls it on the linear (Rec.709, "linear
// sRGB") colour before its colour-space (sRGB OETF) step, so the functions'
// results, evaluated here, are the linear display values. The uniform
// toneMappingExposure is the renderer's default, 1.0. Evaluated:
//   ACESFilmicToneMapping  color *= toneMappingExposure / 0.6 (three's own
//       brightening, 1/0.6), ACESInputMat (sRGB -> AP1 with the RRT
//       saturation folded in), RRTAndODTFit (Stephen Hill's rational fit),
//       ACESOutputMat (back to linear sRGB), saturate (clamp to [0, 1]).
//   AgXToneMapping  color *= toneMappingExposure, LINEAR_SRGB_TO_LINEAR_REC2020,
//       AgXInsetMatrix, max(color, 1e-10), log2, normalise over
//       [AgxMinEv, AgxMaxEv] = [-12.47393, 4.026069], clamp to [0, 1],
//       agxDefaultContrastApprox (6th-order polynomial), AgXOutsetMatrix,
//       pow(max(0, color), 2.2), LINEAR_REC2020_TO_LINEAR_SRGB, clamp to
//       [0, 1]. three applies no AgX look (its `agxLook` line is a comment).
//   NeutralToneMapping  color *= toneMappingExposure, then Khronos PBR Neutral
//       (StartCompression = 0.8 - 0.04, Desaturation = 0.15); no clamp.
//
// glsl-tone-map (npm, Damien Seguin, MIT): its agx.glsl text (the package's
// AGX export), for the AgX "punchy" look that three.js does not have:
//   agxPunchy(color) = agxCdl(color, slope vec3(1.0), offset vec3(0.0),
//       power vec3(1.35), saturation 1.4): three's AgX pipeline with, between
//       the sigmoid and the outset matrix, the ASC CDL
//       color = pow(color * slope + offset, power);
//       luma = dot(color, vec3(0.2126, 0.7152, 0.0722));
//       color = luma + saturation * (color - luma)
//   (luma taken after the power, per ASC CDL; glsl-tone-map 2.2.0's
//   changelog: "compute luminance for saturation after ASC CDL transform").
//   The sigmoid is negative below its root near 0.0186 (-0.00232 at 0), so
//   for inputs dark enough that a channel's log encoding falls below it (a
//   channel under about 2.2e-4 after the inset matrix: black, near-black,
//   greys up to 2e-4 here), pow(negative, 1.35) is undefined in GLSL (NaN in
//   practice): those outputs are null here.
//   Its agx(color) (the look with slope 1, power 1, saturation 1) is
//   evaluated too and must equal three's AgXToneMapping bit for bit wherever
//   it is defined (its pow(color, 1.0) is undefined on the same dark inputs):
//   the two packages' texts cross-check each other and this evaluator.

import { createHash } from 'node:crypto';
import { readFileSync } from 'node:fs';

import { AGX } from 'glsl-tone-map';
import { REVISION, ShaderChunk } from 'three';

import { GlslUndefined, Program } from './glsl_subset.mjs';

const here = new URL('.', import.meta.url);

function installedVersion(name) {
  const pinned = JSON.parse(readFileSync(new URL('package.json', here), 'utf8')).dependencies[name];
  const installed = JSON.parse(readFileSync(new URL(`node_modules/${name}/package.json`, here), 'utf8')).version;
  if (installed !== pinned) {
    throw new Error(`${name} ${installed} is installed, package.json pins ${pinned}: run npm ci in tests/operators`);
  }
  return installed;
}

const sha256 = (text) => createHash('sha256').update(text).digest('hex');

// The text of the first match of `pattern`'s group 1 in a package's source,
// whitespace collapsed: constants are recorded as the package writes them.
function sourceText(label, text, pattern) {
  const m = pattern.exec(text);
  if (!m) throw new Error(`${label}: no match for ${pattern}: the package text changed`);
  return m[1].replace(/\s+/g, ' ').trim();
}

function compile(label, source, functions, options) {
  if (typeof source !== 'string' || !source.length) throw new Error(`${label}: no shader text`);
  const program = new Program(source, options);
  for (const name of functions) {
    if (!program.has(name)) throw new Error(`${label} has no function ${name}: the package text changed`);
  }
  return program;
}

// Runs each named function on every input; null (and a reason) where the
// result is undefined in GLSL.
function run(program, functions, inputs, undefinedResults) {
  const out = {};
  for (const [key, name] of Object.entries(functions)) {
    out[key] = inputs.map((rgb, index) => {
      try {
        return program.call(name, rgb);
      } catch (e) {
        if (!(e instanceof GlslUndefined)) throw e;
        undefinedResults.push({ operator: key, index, reason: e.kind });
        return null;
      }
    });
  }
  return out;
}

function main() {
  const { inputs } = JSON.parse(readFileSync(0, 'utf8'));
  if (!Array.isArray(inputs) || !inputs.every((v) => Array.isArray(v) && v.length === 3)) {
    throw new Error('stdin must be {"inputs": [[r, g, b], ...]}');
  }

  const threeText = ShaderChunk.tonemapping_pars_fragment;
  const threeFunctions = {
    aces_filmic: 'ACESFilmicToneMapping',
    agx: 'AgXToneMapping',
    neutral: 'NeutralToneMapping',
  };
  const three = compile('three.js tonemapping_pars_fragment', threeText, Object.values(threeFunctions),
    { uniforms: { toneMappingExposure: 1.0 } });
  if (three.has('agxLook')) throw new Error('three.js now has an AgX look: revisit the punchy reference');
  const threeUndefined = [];
  const threeOut = run(three, threeFunctions, inputs, threeUndefined);

  const gtm = compile('glsl-tone-map agx.glsl', AGX, ['agx', 'agxPunchy', 'agxCdl']);
  const gtmUndefined = [];
  const gtmOut = run(gtm, { agx_punchy: 'agxPunchy', agx: 'agx' }, inputs, gtmUndefined);

  // glsl-tone-map's plain agx and three's AgX are the same operations, except
  // that glsl-tone-map's look step runs pow(color, 1.0) even on the sigmoid's
  // negative values (undefined in GLSL) where three runs nothing: they must
  // agree bit for bit wherever glsl-tone-map's result is defined.
  let compared = 0;
  inputs.forEach((rgb, i) => {
    const a = threeOut.agx[i];
    const b = gtmOut.agx[i];
    if (b === null) return;
    compared++;
    if (a === null || a.some((x, k) => x !== b[k])) {
      throw new Error(`input ${i} ${JSON.stringify(rgb)}: three AgX ${JSON.stringify(a)} != glsl-tone-map agx ${JSON.stringify(b)}`);
    }
  });
  if (compared < inputs.length / 2) throw new Error(`three's and glsl-tone-map's AgX compared on only ${compared} inputs`);
  delete gtmOut.agx;
  const gtmPunchyUndefined = gtmUndefined.filter((u) => u.operator === 'agx_punchy');

  process.stdout.write(JSON.stringify({
    three: {
      version: installedVersion('three'),
      revision: REVISION,
      source: 'three/src/renderers/shaders/ShaderChunk/tonemapping_pars_fragment.glsl.js (ShaderChunk.tonemapping_pars_fragment)',
      source_sha256: sha256(threeText),
      uniforms: { toneMappingExposure: 1.0 },
      functions: threeFunctions,
      neutral_constants: {
        StartCompression: sourceText('three', threeText, /const float StartCompression = ([^;]+);/),
        Desaturation: sourceText('three', threeText, /const float Desaturation = ([^;]+);/),
      },
      ...threeOut,
      undefined: threeUndefined,
    },
    glsl_tone_map: {
      version: installedVersion('glsl-tone-map'),
      source: 'glsl-tone-map/agx.glsl.js (the AGX export; the same text as agx.glsl)',
      source_sha256: sha256(AGX),
      functions: { agx_punchy: 'agxPunchy' },
      // The look's parameters and luma weights, as the text writes them.
      punchy_call: sourceText('glsl-tone-map', AGX, /vec3 agxPunchy\(vec3 color\) \{\s*return ([^;]+);/),
      luma_weights: sourceText('glsl-tone-map', AGX, /const vec3 lw = ([^;]+);/),
      ...gtmOut,
      undefined: gtmPunchyUndefined,
    },
  }) + '\n');
}

main();
