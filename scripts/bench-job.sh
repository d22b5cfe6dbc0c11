#!/usr/bin/env bash
# The whole-job benchmark: whole processes of `shprobe bake` on real files, timed with hyperfine,
# each against the bound a whole bake cannot beat, measured in the same run (docs/benchmark.md):
#   - start: a minimal C program (`int main(void) { return 0; }`, cc -O2) started the same way;
#   - decode alone: the same file read in process by the library's own reader (`shprobe bench
#     --decode`, which calls readImage and follows whatever reader it uses; no Vulkan), best of N.
# Rows: `shprobe --help` and bakes of the built-in sky (bound: start); bakes of a blender-data
# equirect (courtyard.exr), of a horizontal cross and of six face files made from it by shprobe
# itself (`shprobe bench --write-layouts`) (bound: start + decode alone); a batch of the eight
# blender-data HDRs with --out-dir (bound: the sum of their eight decodes, i.e. the decode-alone
# throughput). Orders 3 and 5, the default face size and --face-size 1024, backends auto (the
# default: rows without --backend), gpu, cpu and reference. Each row: the median wall time, its bound, the ratio, and the peak memory (max RSS,
# /usr/bin/time, one extra run); file bakes also show their peak above the same bake of the
# built-in sky (a run with no input file). File and batch rows also show `x once`: the median over
# the bound with each decode as a process meets it, once per file (the median of each
# measurement's first decode of the file); the best decode is of a file read again and again,
# whose data the caches hold.
#
#   bash scripts/bench-job.sh [--quick] [--json FILE] [--build DIR] [--runs N] [--warmup N]
#
# --quick: order 3 only, 3 runs after 1 warmup (about 3 minutes; for checking the script, not for
# figures). Default: 10 runs after 2 warmups per row (rows whose first run takes under 50 ms: 100
# runs; over 2 s: 5 runs after 1): the warmups fill the page cache and the pipeline cache (SHPROBE_CACHE_DIR, in the
# temporary folder), and the median of 10 keeps a busy 2-core VM's outliers (another process
# taking a core for a while) out of the figure, where the mean would not. The decodes are
# measured before and after the rows (best of 20) and before each row (best of 5), and a file's
# bound is its best of all: the fastest the machine decoded it in the run. About 15 minutes on
# such a VM. --build: the build folder holding shprobe (default build). It installs nothing:
# scripts/install-deps.sh installs hyperfine, time and python3. --json FILE: every row (all of
# hyperfine's statistics, the command, its bound), the decodes and the machine.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build"
json=""
quick=0
runs=""
warmup=""
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --json) json="$2"; shift ;;
    --build) build="$2"; shift ;;
    --runs) runs="$2"; shift ;;
    --warmup) warmup="$2"; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-job: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
  shift
done
if [ "$quick" -eq 1 ]; then
  runs="${runs:-3}"; warmup="${warmup:-1}"; orders=(3); decode_repeat=3; row_decode_repeat=3
else
  runs="${runs:-10}"; warmup="${warmup:-2}"; orders=(3 5); decode_repeat=20; row_decode_repeat=5
fi

for tool in hyperfine python3 cc; do
  command -v "$tool" >/dev/null || { echo "bench-job: $tool is missing (bash scripts/install-deps.sh)" >&2; exit 1; }
done
[ -x /usr/bin/time ] || { echo "bench-job: /usr/bin/time is missing (package time; bash scripts/install-deps.sh)" >&2; exit 1; }
shprobe="$(cd "$build" && pwd)/shprobe"
[ -x "$shprobe" ] || { echo "bench-job: no $shprobe (build it first: cmake --build $build --target shprobe_cli)" >&2; exit 1; }
world=/usr/share/blender/datafiles/studiolights/world
[ -f "$world/courtyard.exr" ] || { echo "bench-job: no $world (package blender-data)" >&2; exit 1; }
eight=("$world"/*.exr)
[ "${#eight[@]}" -eq 8 ] || { echo "bench-job: expected eight EXRs in $world, found ${#eight[@]}" >&2; exit 1; }
courtyard="$world/courtyard.exr"

tmp="$(mktemp -d "${TMPDIR:-/tmp}/shprobe-bench-job.XXXXXX")"
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/rows" "$tmp/work"
export SHPROBE_CACHE_DIR="$tmp/cache" # warmed by each row's warmups, as a user's second run is

# The start bound.
printf 'int main(void) { return 0; }\n' >"$tmp/minimal.c"
cc -O2 -o "$tmp/minimal" "$tmp/minimal.c"

# The other layouts, made from courtyard.exr by shprobe's own loader and writer.
"$shprobe" bench --write-layouts "$courtyard" "$tmp/layouts" >/dev/null
cross="$tmp/layouts/cross.exr"
faces=("$tmp"/layouts/faces/{px,nx,py,ny,pz,nz}.exr)

# Decode alone, in process (`shprobe bench --decode`): every file any row reads, before the rows
# and after them (best of $decode_repeat each), and the files of each row again just before it
# (best of $row_decode_repeat). A file's bound is its best over all of these: on a shared machine
# any one of them may meet a busy moment.
# shellcheck disable=SC2034 # read through namerefs (declare -n files=decode_KEY)
{
  decode_courtyard=("$courtyard")
  decode_cross=("$cross")
  decode_faces=("${faces[@]}")
  decode_eight=("${eight[@]}")
}
decode() { # OUTPUT REPEAT FILE...
  local output="$1" repeat="$2"
  shift 2
  "$shprobe" bench --decode "$@" --repeat "$repeat" --json "$output" >/dev/null
}
mkdir -p "$tmp/decode"
echo "decode alone: shprobe bench --decode, best of $decode_repeat per file" >&2
decode "$tmp/decode/before.json" "$decode_repeat" "${eight[@]}" "$cross" "${faces[@]}"
{
  for key in courtyard cross faces eight; do
    declare -n key_files="decode_$key"
    for f in "${key_files[@]}"; do printf '%s\t%s\n' "$key" "$f"; done
  done
} >"$tmp/decode-keys.tsv"
unset -n key_files
echo "load average at the start: $(cut -d' ' -f1-3 /proc/loadavg)" >"$tmp/load.txt"

# The rows: id, input, backend, order, face, bound, label, then the command's words.
rows=0
: >"$tmp/rows.tsv"
row() { # INPUT BACKEND ORDER FACE BOUND LABEL -- COMMAND...
  local input="$1" backend="$2" order="$3" face="$4" bound="$5" label="$6"
  shift 7
  rows=$((rows + 1))
  local id
  id="$(printf '%02d' "$rows")"
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$id" "$input" "$backend" "$order" "$face" "$bound" "$label" "$*" \
    >>"$tmp/rows.tsv"
  if [ "${bound#*:}" != "$bound" ]; then
    local -n row_files="decode_${bound#*:}"
    decode "$tmp/decode/$id.json" "$row_decode_repeat" "${row_files[@]}"
  fi
  # A first run, the first warmup, sizes the row: one under 50 ms (the minimal program, --help)
  # gets ten times the runs, since a start's median needs many; one over 2 s half the runs (at
  # least 3) and no further warmup, so that the slowest rows do not take most of the time.
  (cd "$tmp/work" && /usr/bin/time -f %e -o "$tmp/rows/$id.first" "$@" >/dev/null 2>&1)
  local row_runs="$runs" row_warmup=$((warmup > 0 ? warmup - 1 : 0))
  if awk '{ exit !($NF < 0.05) }' "$tmp/rows/$id.first"; then
    row_runs=$((runs * 10))
  elif awk '{ exit !($NF > 2.0) }' "$tmp/rows/$id.first"; then
    row_runs=$((runs / 2 < 3 ? 3 : runs / 2)) row_warmup=0
  fi
  echo "[$id] $label ($row_runs runs)" >&2
  (cd "$tmp/work" && hyperfine -N --style none --warmup "$row_warmup" --runs "$row_runs" \
    --export-json "$tmp/rows/$id.json" --command-name "$label" "$*" >/dev/null)
  (cd "$tmp/work" && /usr/bin/time -f %M -o "$tmp/rows/$id.mem" "$@" >/dev/null 2>&1)
}

row start - - - self "start: minimal C program" -- "$tmp/minimal"
row help - - - start "shprobe --help" -- "$shprobe" --help
for backend in auto gpu cpu reference; do
  for order in "${orders[@]}"; do
    for face in default 1024; do
      opts=()
      [ "$order" = 3 ] || opts+=(--order "$order")
      [ "$face" = default ] || opts+=(--face-size "$face")
      [ "$backend" = auto ] || opts+=(--backend "$backend")
      shown="${opts[*]}"
      shown="${shown:+ $shown}"
      row sky "$backend" "$order" "$face" start "bake (built-in sky)$shown" -- "$shprobe" bake "${opts[@]}"
      row equirect "$backend" "$order" "$face" file:courtyard "bake courtyard.exr$shown" -- \
        "$shprobe" bake "$courtyard" "${opts[@]}"
      row cross "$backend" "$order" "$face" file:cross "bake cross.exr$shown" -- \
        "$shprobe" bake "$cross" "${opts[@]}"
      row faces "$backend" "$order" "$face" file:faces "bake faces/$shown" -- \
        "$shprobe" bake "$tmp/layouts/faces" "${opts[@]}"
      # Not the reference's batch at 1024: eight bakes of 1-2 s each, past the seconds at most
      # that the reference is measured within.
      [ "$backend" = reference ] && [ "$face" = 1024 ] && continue
      row batch "$backend" "$order" "$face" batch:eight "bake --out-dir (the eight)$shown" -- \
        "$shprobe" bake --out-dir "$tmp/work/batch" "${eight[@]}" "${opts[@]}"
    done
  done
done

echo "decode alone: shprobe bench --decode, best of $decode_repeat per file" >&2
decode "$tmp/decode/after.json" "$decode_repeat" "${eight[@]}" "$cross" "${faces[@]}"
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)" >>"$tmp/load.txt"

# The machine, for the report.
{
  echo "cpu: $(lscpu | sed -n 's/^Model name: *//p' | head -1), $(nproc) cores"
  echo "memory: $(free -g | awk '/^Mem:/ {print $2}') GiB"
  echo "os: $(sed -n 's/^PRETTY_NAME="\{0,1\}\([^"]*\)"\{0,1\}$/\1/p' /etc/os-release)"
  "$shprobe" info 2>&1 | sed -n 's/^ *//; /^device 0/p; /^Vulkan/p' | head -2
  cat "$tmp/load.txt"
} >"$tmp/machine.txt"

python3 - "$tmp" "$json" "$runs" "$warmup" "$decode_repeat" "$row_decode_repeat" "$quick" <<'PY'
import glob, json, statistics, sys
tmp, out, runs, warmup, decode_repeat, row_decode_repeat, quick = sys.argv[1:]
MiB = 1024.0 * 1024.0

# Each file's decode: its best over every measurement of the run (before, before each row, after).
decode = json.load(open(f"{tmp}/decode/before.json"))
samples, firsts = {}, {}
for name in sorted(glob.glob(f"{tmp}/decode/*.json")):
    for f in json.load(open(name))["files"]:
        samples.setdefault(f["path"], []).append(f["best_seconds"])
        firsts.setdefault(f["path"], []).append(f["first_seconds"])
for f in decode["files"]:
    f["measurements"] = len(samples[f["path"]])
    f["best_seconds_of_each_measurement"] = samples[f["path"]]
    f["best_seconds"] = min(samples[f["path"]])
    # A file decoded once in a process, as a bake decodes it: the median of the first decodes.
    f["once_seconds"] = statistics.median(firsts[f["path"]])
decode["total_best_seconds"] = sum(f["best_seconds"] for f in decode["files"])
decode["repeat"] = {"before_and_after": int(decode_repeat), "before_each_row": int(row_decode_repeat)}
decoded = {f["path"]: f for f in decode["files"]}
keys = {}
for line in open(f"{tmp}/decode-keys.tsv"):
    key, path = line.rstrip("\n").split("\t")
    keys.setdefault(key, []).append(decoded[path])
machine = [line.strip() for line in open(f"{tmp}/machine.txt") if line.strip()]

rows = []
for line in open(f"{tmp}/rows.tsv"):
    rid, inp, backend, order, face, bound, label, command = line.rstrip("\n").split("\t")
    result = json.load(open(f"{tmp}/rows/{rid}.json"))["results"][0]
    peak_kib = int(open(f"{tmp}/rows/{rid}.mem").read().split()[-1])
    rows.append(dict(id=rid, input=inp, backend=backend, order=order, face=face, bound_kind=bound,
                     label=label, command=command, median=result["median"], mean=result["mean"],
                     stddev=result["stddev"], min=result["min"], max=result["max"],
                     runs=len(result["times"]), peak_kib=peak_kib))

start = rows[0]["median"]
sky = {(r["backend"], r["order"], r["face"]): r for r in rows if r["input"] == "sky"}
for r in rows:
    kind, _, key = r["bound_kind"].partition(":")
    if kind == "self":
        r["bound"] = r["median"]
    elif kind == "start":
        r["bound"] = start
    elif kind == "file":
        r["decode_seconds"] = sum(f["best_seconds"] for f in keys[key])
        r["decoded_bytes"] = sum(f["decoded_bytes"] for f in keys[key])
        r["bound"] = start + r["decode_seconds"]
        r["bound_once"] = start + sum(f["once_seconds"] for f in keys[key])
    else:  # batch: the decode-alone throughput of the same files
        r["decode_seconds"] = sum(f["best_seconds"] for f in keys[key])
        r["decoded_bytes"] = sum(f["decoded_bytes"] for f in keys[key])
        r["bound"] = r["decode_seconds"]
        r["bound_once"] = sum(f["once_seconds"] for f in keys[key])
        r["fraction_of_decode_throughput"] = r["decode_seconds"] / r["median"]
    r["ratio"] = r["median"] / r["bound"]
    if "bound_once" in r:
        r["ratio_once"] = r["median"] / r["bound_once"]
    base = sky.get((r["backend"], r["order"], r["face"]))
    if r["input"] in ("equirect", "cross", "faces", "batch") and base:
        r["peak_over_no_input_kib"] = r["peak_kib"] - base["peak_kib"]

lines = []
lines += machine
lines.append(f"runs: {runs} after {warmup} warmups per row (median; rows under 50 ms: 10x, over 2 s: half); decode alone: "
             f"best of {decode_repeat} before and after the rows and of {row_decode_repeat} before each; "
             f"minimal start {start * 1e3:.2f} ms")
lines.append("")
lines.append("decode alone (readImage, in process)    pixels      MiB   best ms  median of bests  measured  first ms  once ms")
for f in decode["files"]:
    name = "/".join(f["path"].split("/")[-2:]) if "/faces/" in f["path"] else f["path"].split("/")[-1]
    lines.append(f"  {name:34s} {f['width']:>5d}x{f['height']:<5d} {f['decoded_bytes'] / MiB:6.1f} "
                 f"{f['best_seconds'] * 1e3:9.2f} {statistics.median(samples[f['path']]) * 1e3:16.2f} "
                 f"{f['measurements']:9d} {f['first_seconds'] * 1e3:9.2f} {f['once_seconds'] * 1e3:8.2f}")
lines.append("")
w = max(len(r["label"]) for r in rows)
lines.append(f"{'row':{w}s}  {'median s':>9s} {'min s':>8s} {'bound s':>8s} {'x bound':>8s} {'x once':>7s} "
             f"{'peak MiB':>9s} {'+MiB vs sky':>11s}")
for r in rows:
    over = r.get("peak_over_no_input_kib")
    over_text = f"{over / 1024.0:11.1f}" if over is not None else f"{'':11s}"
    once_text = f"{r['ratio_once']:7.2f}" if "ratio_once" in r else f"{'':7s}"
    lines.append(f"{r['label']:{w}s}  {r['median']:9.4f} {r['min']:8.4f} {r['bound']:8.4f} {r['ratio']:8.2f} {once_text} "
                 f"{r['peak_kib'] / 1024.0:9.1f} {over_text}")

# The targets the job will be judged by, as measured (not pass/fail of this script).
def find(inp, backend="auto", order="3", face="default"):
    return next((r for r in rows if r["input"] == inp and r["backend"] == backend and r["order"] == order
                 and r["face"] == face), None)
help_row = next(r for r in rows if r["input"] == "help")
bake = find("equirect")
gpu_bake = find("equirect", backend="gpu")
batch = find("batch")
targets = [
    ("shprobe --help within 3x of the minimal start", help_row["ratio"], help_row["ratio"] <= 3.0,
     f"{help_row['ratio']:.2f}x"),
    ("bake courtyard.exr (defaults) within 1.5x of start + decode", bake["ratio"], bake["ratio"] <= 1.5,
     f"{bake['ratio']:.2f}x"),
    ("bake courtyard.exr --backend gpu within 3x of start + decode", gpu_bake["ratio"], gpu_bake["ratio"] <= 3.0,
     f"{gpu_bake['ratio']:.2f}x"),
    ("batch of the eight (defaults) at least 80% of decode throughput", batch["fraction_of_decode_throughput"],
     batch["fraction_of_decode_throughput"] >= 0.8, f"{batch['fraction_of_decode_throughput'] * 100:.0f}%"),
    ("bake courtyard.exr peak at most decoded image + 64 MiB above the sky's",
     bake["peak_over_no_input_kib"] / 1024.0,
     bake["peak_over_no_input_kib"] <= (bake["decoded_bytes"] / 1024.0 + 64 * 1024),
     f"+{bake['peak_over_no_input_kib'] / 1024.0:.1f} MiB (decoded {bake['decoded_bytes'] / MiB:.1f} MiB + 64)"),
]
lines.append("")
lines.append("targets (order 3, default face size; backend auto unless named)")
for text, _, met, shown in targets:
    lines.append(f"  {text:70s} {shown:>32s}  {'met' if met else 'not met'}")
print("\n".join(lines))

if out:
    report = dict(machine=machine, quick=quick == "1", runs=int(runs), warmup=int(warmup),
                  minimal_start_seconds=start, decode=decode,
                  rows=rows,
                  targets=[dict(target=t, value=v, met=m) for t, v, m, _ in targets])
    with open(out, "w") as f:
        json.dump(report, f, indent=2)
        f.write("\n")
PY
