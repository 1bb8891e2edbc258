#!/usr/bin/env bash
# What anyone with a GPU runs: a release build, then on one adapter (default
# the best hardware one, `--adapter hardware`) the gate (`check`, FLIP on the
# GPU, and again with `--metrics cpu`), the stiff inputs (`stress --json`)
# and the frame benchmark (`bench --json` at 720p, 1080p and 2160p, staged
# with FLIP timed at the size, and fused; with each TAA variant at 1600x900,
# seed 002's size, and 1080p), all into one report folder:
#   ci/gpu.sh [OUT_DIR] [ADAPTER]        (default: gpu-report, hardware)
# Exits 0 only if check and stress pass; the bench never decides. The GL
# adapter of the same GPU is tried too: it passes the gate or is refused
# with its reason (a GL context without compute shaders).
# It ends with one screen to paste into a note (also summary.txt).
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

# The same GPU through GL: the gate, or a refusal that names what it lacks.
"$TONEGATE" check --adapter "$adapter" --backend gl --no-history \
  --json "$out/check-gl.json" >"$out/check-gl.txt" 2>&1
gl=$?

# The same gate with FLIP on the CPU (nv-flip), for its phase times beside
# the GPU's (`--metrics auto` takes the GPU on a hardware adapter).
"$TONEGATE" check --adapter "$adapter" --no-history --metrics cpu \
  --json "$out/check-metrics-cpu.json" >"$out/check-metrics-cpu.txt" 2>&1

for size in 1280x720 1920x1080 3840x2160; do
  for execution in staged fused; do
    # The staged runs time FLIP at the size too, on the GPU and on the CPU.
    flip=()
    [ "$execution" = staged ] && flip=(--flip)
    "$TONEGATE" bench --adapter "$adapter" --size "$size" --execution "$execution" "${flip[@]}" \
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
# motion feedback, tone-mapped blend), the defaults with the history read
# through the texture unit's filter (9 taps instead of 16 loads), and the
# thesis's own TAA (bilinear, luminance feedback, linear blend).
for size in 1600x900 1920x1080; do
  for taa in clip edge-aware variance; do
    for keys in default hardware thesis; do
      name="$size-taa-$taa-$keys"
      extra=()
      if [ "$keys" = thesis ]; then
        extra=(--taa-history bilinear --taa-feedback luminance --taa-blend linear)
      elif [ "$keys" = hardware ]; then
        extra=(--env-filter hardware)
      fi
      "$TONEGATE" bench --adapter "$adapter" --size "$size" --taa "$taa" "${extra[@]}" \
        --frames "${BENCH_FRAMES:-300}" --json >"$out/bench-$name.json" \
        2>"$out/bench-$name.err" || echo "bench $name failed" >&2
    done
  done
done

python3 - "$out" "$check" "$stress" "$gl" <<'PY' | tee "$out/summary.txt"
import glob, json, os, sys
out, check, stress, gl = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        return {"error": f"{path}: {e}"}
def text(path):
    try:
        with open(path) as f:
            return f.read()
    except OSError:
        return ""
report = {
    "check_exit": check,
    "stress_exit": stress,
    "check_gl_exit": gl,
    "check": load(os.path.join(out, "check.json")),
    "check_gl": load(os.path.join(out, "check-gl.json")),
    "stress": load(os.path.join(out, "stress.json")),
    "adapters": load(os.path.join(out, "adapters.json")),
    "bench": {os.path.basename(p)[6:-5]: load(p) for p in sorted(glob.glob(os.path.join(out, "bench-*.json")))},
}
with open(os.path.join(out, "report.json"), "w") as f:
    json.dump(report, f, indent=1)
c = report["check"] if isinstance(report["check"], dict) else {}
a = c.get("adapter") or {}
flush = {True: "flushed", False: "kept"}.get(a.get("flushes_subnormals"), "?")
print(f"adapter: {a.get('name', '?')} ({a.get('backend', '?')}, driver {a.get('driver', '?')} {a.get('driver_info', '')})")
print(f"  subnormals {flush}; divisions {a.get('division', '?')}")
scenes = c.get("scenes") or []
bad = [s.get("scene", "?") for s in scenes if any(k.get("passed") is False for k in s.get("checks", []))]
print(f"check: exit {check}; {len(scenes) - len(bad)}/{len(scenes)} scenes pass" + (f"; failing: {', '.join(bad)}" if bad else ""))
cm = load(os.path.join(out, "check-metrics-cpu.json"))
report["check_metrics_cpu"] = cm
for label, rep in (("check's phases", c), ("check --metrics cpu", cm if isinstance(cm, dict) else {})):
    ph = rep.get("phases") or {}
    if not ph:
        continue
    keys = ["device", "pipelines", "render", "readback_wait", "readback_copy", "goldens", "metrics",
            "ssim", "flip", "errors", "fraction_over", "gpu_metrics", "artifacts", "history", "stress", "stress_cpu", "stress_gpu"]
    print(f"{label} (s; metrics on {rep.get('metrics_on', '?')}): total {ph.get('total_s', 0):.2f}; "
          + ", ".join(f"{k} {ph.get(k + '_s', 0):.2f}" for k in keys))
for name, st in (("check's stress", c.get("stress")), ("stress", report["stress"])):
    rows = (st or {}).get("cases") or []
    fails = [r for r in rows if not r.get("passed")]
    exit_note = f"exit {stress}; " if name == "stress" else ""
    print(f"{name}: {exit_note}{len(rows) - len(fails)}/{len(rows)} rows pass")
    for r in fails[:10]:
        print(f"  FAIL {r.get('name')} on {r.get('renderer')}: finite {r.get('finite')}, max rel {r.get('max_rel_error')}, bound {r.get('bound')}, {r.get('max_lsb_vs_cpu')} LSB from the CPU; {r.get('observed', '')}")
gl_first = next((l for l in text(os.path.join(out, "check-gl.txt")).splitlines() if l.strip()), "")
if gl == 0:
    print("GL: check exit 0")
else:
    print(f"GL: check exit {gl}: {gl_first[:200]}")
print()
print(f"{'bench (p50)':<34} {'GPU ms':>8} {'+readback':>10} {'serial':>8} {'wait':>7} {'copy':>7} {'floor ms':>9}  stages (x floor)")
for name, b in report["bench"].items():
    if "error" in b:
        print(f"{name:<34} {b['error'][:80]}")
        continue
    gpu = (b.get("frame_gpu_ms") or {}).get("p50")
    rb = (b.get("frame_wall_ms_with_readback") or {}).get("p50")
    serial = (b.get("frame_wall_ms_serial") or {}).get("p50")
    split = b.get("readback_serial") or {}
    stages = ", ".join(f"{s['name']} {s['floor_multiple']:.2f}" for s in b.get("stages", []))
    fmt = lambda v: f"{v:.3f}" if isinstance(v, (int, float)) else "?"
    print(f"{name:<34} {fmt(gpu):>8} {fmt(rb):>10} {fmt(serial):>8} {fmt(split.get('wait_ms')):>7} "
          f"{fmt(split.get('copy_ms')):>7} {fmt(b.get('floor_ms')):>9}  {stages}")
for name, b in report["bench"].items():
    f = b.get("flip") if isinstance(b, dict) else None
    if f:
        print(f"FLIP {f['size']}: GPU {f['gpu_ms']:.2f} ms, nv-flip {f['cpu_ms']:.2f} ms; means {f['gpu_mean']:.6f} / {f['cpu_mean']:.6f}; "
              f"every metric: GPU {f['gpu_all_ms']:.2f} ms, CPU {f['cpu_all_ms']:.2f} ms")
# The targets for a hardware GPU (docs/adapters.md#targets-on-a-gpu), each
# with its figure from this run and its ratio to the bound.
def stage(bench_name, stage_name):
    b = report["bench"].get(bench_name) or {}
    for s in b.get("stages", []) if isinstance(b, dict) else []:
        if s.get("name") == stage_name:
            return s.get("floor_multiple")
    return None
def p50(bench_name, key):
    b = report["bench"].get(bench_name) or {}
    return (b.get(key) or {}).get("p50") if isinstance(b, dict) else None
flip = (report["bench"].get("1920x1080-staged") or {}).get("flip") or {}
targets = [
    ("1080p fused frame with readback, ms", p50("1920x1080-fused", "frame_wall_ms_with_readback"), 0.5),
    ("2160p fused frame with readback, ms", p50("3840x2160-fused", "frame_wall_ms_with_readback"), 2.0),
    ("check of the built-in suite, s", ((c.get("phases") or {}).get("total_s")), 5.0),
    ("FLIP at 1080p on the GPU, ms", flip.get("gpu_ms"), 5.0),
]
for size in ("1600x900", "1920x1080"):
    for keys in ("default", "hardware"):
        targets.append((f"taa at {size} ({keys} filter), x floor", stage(f"{size}-taa-clip-{keys}", "taa"), 3.0))
    targets.append((f"taa_sobel at {size}, x floor", stage(f"{size}-taa-edge-aware-default", "taa_sobel"), 1.5))
print()
print(f"{'target':<44} {'measured':>10} {'bound':>7} {'ratio':>7}")
for name, value, bound in targets:
    if isinstance(value, (int, float)):
        verdict = "met" if value <= bound else "missed"
        print(f"{name:<44} {value:>10.3f} {bound:>7.2f} {value / bound:>7.2f}  {verdict}")
    else:
        print(f"{name:<44} {'?':>10} {bound:>7.2f}")
print("(not here: the frames judge with the GPU's metrics, `cargo bench --bench frames`;")
print(" the embedding against the renderer, `cargo bench --bench gpu_pipeline`; run them")
print(" in the same call, with a peer such as torch.compile, to compare on one machine)")
with open(os.path.join(out, "report.json"), "w") as fh:
    json.dump(report, fh, indent=1)
print(f"report: {os.path.join(out, 'report.json')}")
PY
exit $status
