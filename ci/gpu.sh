#!/usr/bin/env bash
# What anyone with a GPU runs: a release build, then on one adapter (default
# the best hardware one, `--adapter hardware`) the gate (`check`), the stiff
# inputs (`stress --json`) and the frame benchmark (`bench --json` at 720p,
# 1080p and 2160p, staged and fused; with each TAA variant at 1600x900, seed
# 002's size, and 1080p), all into one report folder:
#   ci/gpu.sh [OUT_DIR] [ADAPTER]        (default: gpu-report, hardware)
# Exits 0 only if check and stress pass; the bench never decides.
# ADAPTER=default runs the same on lavapipe, to try the script without a GPU.
# TONEGATE=path/to/tonegate skips the build (a binary built elsewhere).
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:-gpu-report}
adapter=${2:-hardware}
mkdir -p "$out"
if [ -z "${TONEGATE:-}" ]; then
  cargo build --release --locked || exit 2
  TONEGATE=target/release/tonegate
fi
status=0

# Every adapter the machine has, with the subnormal probe's answer.
"$TONEGATE" adapters --json >"$out/adapters.json" 2>"$out/adapters.err"

"$TONEGATE" check --adapter "$adapter" --no-history \
  --json "$out/check.json" --junit "$out/check.junit.xml" --artifacts "$out/artifacts" \
  >"$out/check.txt" 2>&1
check=$?
[ "$check" = 0 ] || status=1

"$TONEGATE" stress --adapter "$adapter" --json >"$out/stress.json" 2>"$out/stress.err"
stress=$?
[ "$stress" = 0 ] || status=1

for size in 1280x720 1920x1080 3840x2160; do
  for execution in staged fused; do
    "$TONEGATE" bench --adapter "$adapter" --size "$size" --execution "$execution" \
      --frames "${BENCH_FRAMES:-300}" --json >"$out/bench-$size-$execution.json" \
      2>"$out/bench-$size-$execution.err" || echo "bench $size $execution failed" >&2
  done
done

# `--reduction auto` picks the subgroup tree on a GPU with subgroup operations
# (the shared-memory tree without); block partials (llvmpipe's pick) and the
# shared-memory tree at 1080p beside it, so the report compares them on this
# adapter.
for reduction in block tree; do
  "$TONEGATE" bench --adapter "$adapter" --size 1920x1080 --reduction "$reduction" \
    --frames "${BENCH_FRAMES:-300}" --json >"$out/bench-1920x1080-staged-$reduction.json" \
    2>"$out/bench-1920x1080-staged-$reduction.err" || echo "bench 1080p $reduction failed" >&2
done

# The TAA target (docs/taa.md#speed): `taa` within 3x the floor pass and
# `taa_sobel` within 1.5x. Each box with the defaults (Catmull-Rom history,
# motion feedback, tone-mapped blend), and the thesis's own TAA (bilinear,
# luminance feedback, linear blend).
for size in 1600x900 1920x1080; do
  for taa in clip edge-aware variance; do
    for keys in default thesis; do
      name="$size-taa-$taa-$keys"
      extra=()
      if [ "$keys" = thesis ]; then
        extra=(--taa-history bilinear --taa-feedback luminance --taa-blend linear)
      fi
      "$TONEGATE" bench --adapter "$adapter" --size "$size" --taa "$taa" "${extra[@]}" \
        --frames "${BENCH_FRAMES:-300}" --json >"$out/bench-$name.json" \
        2>"$out/bench-$name.err" || echo "bench $name failed" >&2
    done
  done
done

python3 - "$out" "$check" "$stress" <<'PY'
import glob, json, os, sys
out, check, stress = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        return {"error": f"{path}: {e}"}
report = {
    "check_exit": check,
    "stress_exit": stress,
    "check": load(os.path.join(out, "check.json")),
    "stress": load(os.path.join(out, "stress.json")),
    "adapters": load(os.path.join(out, "adapters.json")),
    "bench": {os.path.basename(p)[6:-5]: load(p) for p in sorted(glob.glob(os.path.join(out, "bench-*.json")))},
}
with open(os.path.join(out, "report.json"), "w") as f:
    json.dump(report, f, indent=1)
adapter = report["check"].get("adapter", {}) if isinstance(report["check"], dict) else {}
print(f"adapter: {adapter.get('name', '?')} ({adapter.get('chosen', '?')})")
print(f"check: exit {check}; stress: exit {stress}")
for name, b in report["bench"].items():
    if "error" in b:
        print(f"bench {name}: {b['error']}")
        continue
    print(f"bench {name}: reduction {b.get('config', {}).get('reduction')}; {json.dumps({k: b[k] for k in b if k in ('frame_gpu_ms', 'frame_wall_ms_with_readback', 'frame_wall_ms_serial', 'fps', 'fps_with_readback', 'fps_serial_readback', 'floor_ms', 'floor_rw_ms', 'display_floor_multiple')})}")
    for s in b.get("stages", []):
        if s["name"] == "luminance_stats":
            print(f"  luminance_stats: {s['median_ms']:.3f} ms median, {s['floor_multiple']:.2f}x floor")
    for s in b.get("stages", []):
        if s["name"].startswith("taa"):
            print(f"  {s['name']}: {s['median_ms']:.3f} ms median, {s['floor_multiple']:.2f}x floor")
print(f"report: {os.path.join(out, 'report.json')}")
PY
exit $status
