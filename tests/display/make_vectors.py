"""Reference vectors for tonegate's HDR output (docs/display.md#hdr-output).

For display-relative BT.709 colours v (an operator's output: 0 is the
display's black, 1 its peak) and a display's black and peak in cd/m², each
case gives what colour-science computes:

  light  = RGB_to_RGB(black + clip(v, 0, 1)·(peak − black), BT.709 → BT.2020),
           negative values set to 0
  signal = eotf_inverse_ST2084(light)                  (PQ)
         = eotf_inverse_BT2100_HLG(light, 0, peak)      (HLG, BT.2100-2)
  codes  = floor(clip(signal, 0, 1)·65535 + 0.5)       (16-bit, full range)

Inputs are fixed points (black, white, primaries, greys) and seeded random
colours, all exact f32 values (tonegate's display images are f32).
"""

import json
import sys

import colour
import numpy as np

OUT = "tests/display/vectors.json"

CASES = [
    ("pq_100", "PQ", 0.0, 100.0),
    ("pq_1000_black_0.1", "PQ", 0.1, 1000.0),
    ("pq_203", "PQ", 0.0, 203.0),
    ("hlg_1000", "HLG", 0.0, 1000.0),
    ("hlg_400", "HLG", 0.0, 400.0),
    ("hlg_2000", "HLG", 0.0, 2000.0),
]


def inputs():
    fixed = [
        [0, 0, 0], [1, 1, 1], [0.5, 0.5, 0.5], [0.203, 0.203, 0.203],
        [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [0, 1, 1], [1, 0, 1],
        [1e-6, 1e-6, 1e-6], [1e-3, 2e-3, 5e-4], [0.75, 0.4, 0.1],
        [1.5, 0.2, -0.1],  # beyond the display: clipped
    ]
    rng = np.random.default_rng(20261126)
    rand = rng.random((120, 3)) ** 3  # more darks, as images have
    v = np.vstack([np.array(fixed, dtype=np.float64), rand])
    return v.astype(np.float32).astype(np.float64)


def main():
    v = inputs()
    cases = []
    for name, transfer, black, peak in CASES:
        display = black + np.clip(v, 0.0, 1.0) * (peak - black)
        light = colour.RGB_to_RGB(display, "ITU-R BT.709", "ITU-R BT.2020")
        light = np.maximum(light, 0.0)
        if transfer == "PQ":
            signal = colour.models.eotf_inverse_ST2084(light)
        else:
            signal = colour.models.eotf_inverse_BT2100_HLG(
                light, L_B=0.0, L_W=peak, method="ITU-R BT.2100-2"
            )
        codes = np.floor(np.clip(signal, 0.0, 1.0) * 65535.0 + 0.5).astype(int)
        cases.append({
            "name": name,
            "transfer": transfer,
            "black_nits": black,
            "peak_nits": peak,
            "light": light.tolist(),
            "signal": signal.tolist(),
            "codes": codes.tolist(),
        })
    doc = {
        "generator": "tests/display/make_vectors.sh (tests/display/make_vectors.py)",
        "colour_science": colour.__version__,
        "numpy": np.__version__,
        "note": __doc__.strip(),
        "inputs": v.tolist(),
        "cases": cases,
    }
    with open(OUT, "w") as f:
        json.dump(doc, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {OUT} ({len(v)} colours, {len(cases)} cases)", file=sys.stderr)


if __name__ == "__main__":
    main()
