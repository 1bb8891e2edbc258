#!/usr/bin/env python3
"""Reference values for tonegate's tone-mapping operators.

Writes tests/operators/vectors.json. Run it through make_vectors.sh, which
pins the versions (requirements.txt for Python, package.json and
package-lock.json for npm) and installs them; CI regenerates the file when
the lock's inputs change (ci/locks.sh) and requires it to be the committed one (floats to the last bits a CPU can move:
ci/same_vectors.py).

Every operator is applied to the same `inputs`: linear Rec.709 RGB triplets
(black, near-black, greys from 1e-6 to 1e4, primaries and secondaries at four
intensities, seeded log-uniform random HDR colours, and a few with a slightly
negative channel, as out-of-gamut colours arrive), each value an exact
float32, so that an f32 GPU test can feed them unchanged. `input_labels`
names each one's group. Outputs are linear display RGB (no sRGB or gamma
encoding), binary64, one triplet per input, row-major like the inputs; null
where the reference's result is undefined (`undefined` lists them and why).

The references, each computed independently of tonegate:

  hable  colour-hdri's tonemapping_operator_filmic with its defaults (recorded
      in `hable_params`, read from its signature): Hable's filmic curve
          f(x) = (x (A x + C B) + D E) / (x (A x + B) + D F) - E / F
      with A shoulder_strength 0.22, B linear_strength 0.3, C linear_angle
      0.1, D toe_strength 0.2, E toe_numerator 0.01, F toe_denominator 0.3
      (the Uncharted 2 GDC 2010 slides' values; his blog post uses A 0.15,
      B 0.50, E 0.02), returning f(exposure_bias * x) * (1 / f(W)) with
      exposure_bias 2 and linear_whitepoint W 11.2, per channel. So it does
      pre-multiply by the exposure bias and does divide by the white point's
      curve value; it applies no gamma or other encoding and no clamp (values
      above W exceed 1).

  aces_narkowicz  Krzysztof Narkowicz's fit, written out below in numpy from
      his post "ACES Filmic Tone Mapping Curve" (2016-01-06,
      knarkowicz.wordpress.com/2016/01/06/aces-filmic-tone-mapping-curve/):
          saturate((x * (a * x + b)) / (x * (c * x + d) + e)),
          a 2.51, b 0.03, c 2.43, d 0.59, e 0.14,
      per channel on the raw input: exposure 1, no 0.6 pre-scale.

  three_aces_filmic, three_agx, three_neutral  three.js's own GLSL
      (ShaderChunk.tonemapping_pars_fragment of the pinned npm `three`:
      ACESFilmicToneMapping, AgXToneMapping, NeutralToneMapping with
      toneMappingExposure 1.0), evaluated from the package's text at run time
      by three_vectors.mjs (node) with glsl_subset.mjs, a GLSL-subset
      interpreter in binary64. three_vectors.mjs's header says what each
      function does (ACES: x 1/0.6, Hill's input matrix, RRTAndODTFit, output
      matrix, clamp; AgX: to Rec.2020, inset, log2 encoding, sigmoid, outset,
      2.2 power, back to Rec.709, clamp; Neutral: Khronos PBR Neutral).

  agx_punchy  the AgX "punchy" look (three.js has no AgX look, and neither
      has the glTF Sample Viewer, whose tone maps are Khronos PBR Neutral and
      three ACES variants): glsl-tone-map's agxPunchy, from the pinned npm
      package's agx.glsl text, evaluated the same way: three's AgX pipeline
      with the ASC CDL slope 1, offset 0, power 1.35, saturation 1.4 applied
      between the sigmoid and the outset matrix. Null where the sigmoid is
      negative (dark inputs): pow(negative, 1.35) is undefined in GLSL.

  khronos_neutral_reference  the Khronos PBR Neutral operator computed from
      the Khronos reference GLSL (KhronosGroup/ToneMapping,
      PBR_Neutral/pbrNeutral.glsl, written out below). Khronos publishes no
      input -> output numbers other than its OCIO LUT (pbrNeutral.cube, 57^3
      points on a log2 shaper, 7 decimals, made by its lut-writer.mjs; not in
      the snapshot of the repository these were made from), so these are
      computed numbers, not published ones. three_neutral must equal them bit
      for bit (checked here); the constants of both are recorded side by
      side.
"""

import inspect
import json
import subprocess
import sys
import warnings
from pathlib import Path

# colour-science says at import that matplotlib is absent; nothing here plots.
warnings.filterwarnings("ignore", message='"Matplotlib" related API features')

import colour  # noqa: E402
import colour_hdri  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
OUT = HERE / "vectors.json"
SEED = 20261126

# The Khronos reference implementation, read with the repository tools (CI
# cannot reach it): the last commit that changed the file, and the blob.
KHRONOS_NEUTRAL_SOURCE = {
    "repository": "KhronosGroup/ToneMapping",
    "path": "PBR_Neutral/pbrNeutral.glsl",
    "commit": "f5dc101149fc5c85c0f9852fe2ba438853e8a7d1",
    "blob": "1e0e7e0b22aa1bd33549b4e97dfaef4779548fe2",
    "read_at_head": "b5a2eed5ddf6c2227090449399de9c7affb9e4c9",
    "licence": "Apache-2.0",
}
# Its constants as its text writes them.
KHRONOS_NEUTRAL_CONSTANTS = {"startCompression": "0.8 - 0.04", "desaturation": "0.15"}


def khronos_pbr_neutral(rgb):
    """PBR_Neutral/pbrNeutral.glsl, operation for operation in binary64:

        vec3 PBRNeutralToneMapping( vec3 color ) {
          const float startCompression = 0.8 - 0.04;
          const float desaturation = 0.15;
          float x = min(color.r, min(color.g, color.b));
          float offset = x < 0.08 ? x - 6.25 * x * x : 0.04;
          color -= offset;
          float peak = max(color.r, max(color.g, color.b));
          if (peak < startCompression) return color;
          const float d = 1. - startCompression;
          float newPeak = 1. - d * d / (peak + d - startCompression);
          color *= newPeak / peak;
          float g = 1. - 1. / (desaturation * (peak - newPeak) + 1.);
          return mix(color, newPeak * vec3(1, 1, 1), g);
        }

    with GLSL's mix(x, y, a) = x * (1 - a) + y * a.
    """
    start_compression = 0.8 - 0.04
    desaturation = 0.15
    r, g, b = (float(v) for v in rgb)
    x = min(r, min(g, b))
    offset = x - 6.25 * x * x if x < 0.08 else 0.04
    c = [r - offset, g - offset, b - offset]
    peak = max(c[0], max(c[1], c[2]))
    if peak < start_compression:
        return c
    d = 1.0 - start_compression
    new_peak = 1.0 - d * d / (peak + d - start_compression)
    scale = new_peak / peak
    c = [v * scale for v in c]
    t = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0)
    return [v * (1.0 - t) + new_peak * t for v in c]


def aces_narkowicz(x):
    """Narkowicz 2016, his ACESFilm(x) = saturate((x*(a*x+b))/(x*(c*x+d)+e))."""
    a, b, c, d, e = 2.51, 0.03, 2.43, 0.59, 0.14
    return np.clip((x * (a * x + b)) / (x * (c * x + d) + e), 0.0, 1.0)


def make_inputs():
    """The labelled input triplets, each value rounded to float32."""
    cases = [("black", [0.0, 0.0, 0.0])]
    for v in (1e-8, 1e-7):
        cases.append(("near_black_grey", [v, v, v]))
    cases.append(("near_black_colour", [1e-8, 0.0, 3e-8]))
    # Greys: every third power of two from 2^-20 (about 1e-6) to 2^13, and odd
    # values, among them the operators' landmarks: Neutral's 0.08 (offset) and
    # 0.8 (where compression starts), Hable's white point 11.2 (5.6 after its
    # exposure bias of 2), AgX's middle grey 0.18.
    for e in range(-20, 14, 3):
        cases.append(("grey_pow2", [2.0 ** e] * 3))
    for v in (1e-6, 3e-5, 1e-4, 2e-4, 1e-3, 0.01, 0.03, 0.0799, 0.08, 0.0801, 0.18, 0.3,
              0.5, 0.76, 0.8, 0.84, 1.0, 1.7, 3.0, 5.6, 11.2, 30.0, 100.0, 420.0, 1000.0,
              3000.0, 1e4):
        cases.append(("grey", [v] * 3))
    # Saturated primaries and secondaries.
    hues = {"red": (1, 0, 0), "green": (0, 1, 0), "blue": (0, 0, 1),
            "cyan": (0, 1, 1), "magenta": (1, 0, 1), "yellow": (1, 1, 0)}
    for intensity in (0.1, 1.0, 8.0, 100.0):
        for name, rgb in hues.items():
            cases.append((f"saturated_{name}", [intensity * c for c in rgb]))
    # HDR colours, each channel log-uniform over 1e-3 .. 1e3.
    rng = np.random.default_rng(SEED)
    for rgb in 10.0 ** rng.uniform(-3.0, 3.0, (16, 3)):
        cases.append(("random_hdr", rgb.tolist()))
    # Slightly out of gamut: one channel a little below zero. (Kept above
    # -0.05: Hable's curve has poles at exposure-biased inputs of -0.243 and
    # -1.12, where any implementation is ill-conditioned.)
    for rgb in ([-0.01, 0.5, 0.2], [0.3, -0.002, 0.8], [2.0, 1.0, -0.05],
                [-1e-4, -1e-4, 0.05]):
        cases.append(("negative_channel", rgb))
    labels = [label for label, _ in cases]
    values = np.array([rgb for _, rgb in cases], dtype=np.float64)
    values = values.astype(np.float32).astype(np.float64)
    return labels, values


def triplets(rows):
    """JSON rows: binary64 triplets (ints from node's JSON made floats), or null."""
    return [None if row is None else [float(v) for v in row] for row in rows]


def run_node(inputs):
    """three_vectors.mjs on the inputs (its node_modules from `npm ci`)."""
    proc = subprocess.run(
        ["node", str(HERE / "three_vectors.mjs")],
        input=json.dumps({"inputs": inputs.tolist()}),
        capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr)
        raise SystemExit(f"three_vectors.mjs failed (exit {proc.returncode})")
    return json.loads(proc.stdout)


def main():
    labels, inputs = make_inputs()
    n = len(labels)

    hable_params = {name: p.default for name, p in
                    inspect.signature(colour_hdri.tonemapping_operator_filmic).parameters.items()
                    if p.default is not inspect.Parameter.empty}
    hable = colour_hdri.tonemapping_operator_filmic(inputs)

    node = run_node(inputs)
    three, gtm = node["three"], node["glsl_tone_map"]
    for key in ("aces_filmic", "agx", "neutral"):
        assert len(three[key]) == n
    assert len(gtm["agx_punchy"]) == n
    if three["undefined"]:
        raise SystemExit(f"three.js's operators are undefined on some inputs: {three['undefined']}")

    khronos = [khronos_pbr_neutral(rgb) for rgb in inputs]
    for i, (ours, theirs) in enumerate(zip(khronos, three["neutral"])):
        if ours != theirs:
            raise SystemExit(f"input {i} {inputs[i].tolist()}: Khronos PBR Neutral {ours} "
                             f"!= three.js NeutralToneMapping {theirs}")
    if three["neutral_constants"] != {"StartCompression": KHRONOS_NEUTRAL_CONSTANTS["startCompression"],
                                      "Desaturation": KHRONOS_NEUTRAL_CONSTANTS["desaturation"]}:
        raise SystemExit(f"three's Neutral constants {three['neutral_constants']} are not Khronos's")

    doc = {
        "generator": "tests/operators/make_vectors.py",
        "versions": {
            "three": three["version"],
            "three_revision": three["revision"],
            "glsl_tone_map": gtm["version"],
            "colour_hdri": colour_hdri.__version__,
            "colour_science": colour.__version__,
            "numpy": np.__version__,
        },
        "seed": SEED,
        "inputs": triplets(inputs),
        "input_labels": labels,
        "hable": triplets(hable),
        "hable_params": hable_params,
        "hable_source": "colour_hdri.tonemapping_operator_filmic (defaults)",
        "aces_narkowicz": triplets(aces_narkowicz(inputs)),
        "aces_narkowicz_params": {"a": 2.51, "b": 0.03, "c": 2.43, "d": 0.59, "e": 0.14},
        "three_aces_filmic": triplets(three["aces_filmic"]),
        "three_agx": triplets(three["agx"]),
        "three_neutral": triplets(three["neutral"]),
        "three_source": {
            **{k: three[k] for k in ("source", "source_sha256", "functions", "neutral_constants")},
            "uniforms": {k: float(v) for k, v in three["uniforms"].items()},
        },
        "agx_punchy": triplets(gtm["agx_punchy"]),
        "agx_punchy_source": {
            "package": f"glsl-tone-map@{gtm['version']}",
            "source": gtm["source"],
            "source_sha256": gtm["source_sha256"],
            "function": gtm["functions"]["agx_punchy"],
            # agxCdl(color, slope, offset, power, saturation), as the text calls it.
            "call": gtm["punchy_call"],
            "luma_weights": gtm["luma_weights"],
        },
        "khronos_neutral_reference": {
            "note": "computed by make_vectors.py from the Khronos GLSL (not published numbers); "
                    "equal to three_neutral bit for bit",
            "source": KHRONOS_NEUTRAL_SOURCE,
            "constants": KHRONOS_NEUTRAL_CONSTANTS,
            "three_constants": three["neutral_constants"],
            "outputs": triplets(khronos),
        },
        "undefined": gtm["undefined"],
    }
    OUT.write_text(json.dumps(doc, separators=(",", ":")) + "\n")
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes, {n} inputs, "
          f"{len(doc['undefined'])} undefined outputs)")


if __name__ == "__main__":
    main()
