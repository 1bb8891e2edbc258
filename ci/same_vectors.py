#!/usr/bin/env python3
"""Is a regenerated lock file (tests/*/vectors.json) the committed one?

    python3 ci/same_vectors.py COMMITTED REGENERATED [--rel R]

Keys, lengths, strings, integers and booleans must be equal. Floats must agree
to REL relative: numpy 2 runs its float loops (exp, log, power, reductions)
at the CPU's SIMD level, so the same pinned versions give last-bit differences
on another CPU. Measured: the perceptual vectors committed from one machine
and regenerated on an AMD EPYC with AVX2 but no AVX-512 (numpy "X86_V3")
differed by at most 1.6e-12 relative (a delta E ITP max; 12 scalars moved,
all in the PU21 and delta E ITP results). REL is 60 times that, and 10 times under the tightest
tolerance a test holds us to against these vectors (ITP_REL, 1e-9, in
tests/metrics_perceptual.rs), so a drift the tests could feel still fails here.

--rel R replaces REL for a lock whose reference computes in f32 through the
C library (tests/aces2: OpenColorIO's ACES 2 fixed function calls glibc's
powf, sinf, cosf and atan2f, which glibc picks per CPU, with or without FMA).
Its R is stated next to its call in ci/test.sh.

Prints the first differences with their JSON paths; exit 1 if any.
"""

import json
import math
import sys

REL = 1e-10
SHOWN = 10


def is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def differences(a, b, path="$", rel=REL):
    if is_number(a) and is_number(b) and (isinstance(a, float) or isinstance(b, float)):
        x, y = float(a), float(b)
        if math.isnan(x) and math.isnan(y):
            return
        scale = max(abs(x), abs(y))
        if not abs(x - y) <= rel * scale:
            off = abs(x - y) / scale if scale else math.inf
            yield f"{path}: {x!r} != {y!r} (relative {off:.2e}, allowed {rel:.0e})"
    elif type(a) is not type(b):
        yield f"{path}: {a!r} != {b!r}"
    elif isinstance(a, dict):
        for key in sorted(set(a) | set(b)):
            if key not in a or key not in b:
                yield f"{path}.{key}: only in {'the committed' if key in a else 'the regenerated'} file"
            else:
                yield from differences(a[key], b[key], f"{path}.{key}", rel)
    elif isinstance(a, list):
        if len(a) != len(b):
            yield f"{path}: {len(a)} items != {len(b)}"
            return
        for i, (x, y) in enumerate(zip(a, b)):
            yield from differences(x, y, f"{path}[{i}]", rel)
    elif a != b:
        yield f"{path}: {a!r} != {b!r}"


def main(argv):
    rel = REL
    if len(argv) == 5 and argv[3] == "--rel":
        rel = float(argv[4])
        argv = argv[:3]
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    with open(argv[1]) as f:
        committed = json.load(f)
    with open(argv[2]) as f:
        regenerated = json.load(f)
    found = 0
    for line in differences(committed, regenerated, rel=rel):
        found += 1
        if found <= SHOWN:
            print(f"{argv[2]} {line}", file=sys.stderr)
    if found > SHOWN:
        print(f"... and {found - SHOWN} more", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
