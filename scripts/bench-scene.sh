#!/usr/bin/env bash
# Scene probes per second and memory per probe: `shprobe scene` on both backends (gpu and cpu: rays
# through the texel centres, one per texel) and
# `shprobe-reference` (Embree path tracing, as many directions per probe as a capture has texels)
# on 1,000 and 10,000 probes at faces 32^2, bounce 0, in a Cornell box (36 triangles, written here)
# and, at 1,000 probes, in 2CylinderEngine.glb (121,496 triangles, assimp-testmodels) and in ten
# of it (1,214,960 triangles, cpu and reference: the cost per probe against the triangles); then one
# bounce at 4^3 probes (each backend's defaults, 3 x 3 rays a texel, the cpu's bounces from its
# cache and by paths, against the reference's); then relighting a 32^3 volume baked with its
# transfer, and transfer vectors per second of `shprobe transfer` on both backends in the Cornell
# box and the engine.
# Whole processes, timed by GNU time with their peak memory; memory per probe is the difference of
# the 10,000- and 1,000-probe runs' peaks over the 9,000 probes between them.
#   bash scripts/bench-scene.sh [BUILD_DIR] [OUT.json]
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
json="${2:-}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# The Cornell box as docs/scene-probes.md's tests write it: a 2 m room standing on y = 0, walls
# facing inward (white floor, ceiling and back, red left, green right), a 1 m ceiling light, open
# at the front, with the short and the tall block.
python3 - "$work/cornell.gltf" <<'PY'
import base64, json, struct, sys
quads, materials = [], [([0.73] * 3, [0] * 3), ([0.65, 0.05, 0.05], [0] * 3), ([0.12, 0.45, 0.15], [0] * 3),
                        ([0.73] * 3, [1, 1, 1])]
def quad(c, u, v, m):
    quads.append((c, u, v, m))
def box(c, s, m):  # outward faces of an axis-aligned box
    for a in range(3):
        for sign in (-1, 1):
            n = [0, 0, 0]; n[a] = sign
            u = [0, 0, 0]; u[(a + 1) % 3] = s[(a + 1) % 3] / 2
            v = [0, 0, 0]; v[(a + 2) % 3] = s[(a + 2) % 3] / 2
            if sign < 0: u, v = v, u
            quad([c[i] + n[i] * s[i] / 2 for i in range(3)], u, v, m)
quad([0, 0, 0], [0, 0, 1], [1, 0, 0], 0)          # floor, facing +y
quad([0, 2, 0], [1, 0, 0], [0, 0, 1], 0)          # ceiling, facing -y
quad([0, 1, -1], [1, 0, 0], [0, 1, 0], 0)         # back, facing +z
quad([-1, 1, 0], [0, 1, 0], [0, 0, 1], 1)         # left, facing +x
quad([1, 1, 0], [0, 0, 1], [0, 1, 0], 2)          # right, facing -x
quad([0, 1.998, 0], [0.5, 0, 0], [0, 0, 0.5], 3)  # light, facing -y
box([0.35, 0.3, 0.3], [0.6, 0.6, 0.6], 0)
box([-0.35, 0.6, -0.3], [0.6, 1.2, 0.6], 0)
meshes, data, views, accessors = [], b"", [], []
for m in range(len(materials)):
    pos = []
    for c, u, v, mm in quads:
        if mm != m: continue
        for s, t in ((-1, -1), (1, -1), (1, 1), (-1, -1), (1, 1), (-1, 1)):
            pos.append([c[i] + s * u[i] + t * v[i] for i in range(3)])
    blob = b"".join(struct.pack("<3f", *p) for p in pos)
    views.append({"buffer": 0, "byteOffset": len(data), "byteLength": len(blob)})
    accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": len(pos), "type": "VEC3",
                      "min": [min(p[i] for p in pos) for i in range(3)], "max": [max(p[i] for p in pos) for i in range(3)]})
    meshes.append({"primitives": [{"attributes": {"POSITION": len(accessors) - 1}, "material": m}]})
    data += blob
doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(len(meshes)))}],
       "nodes": [{"mesh": i} for i in range(len(meshes))], "meshes": meshes, "accessors": accessors, "bufferViews": views,
       "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
       "materials": [{"pbrMetallicRoughness": {"baseColorFactor": a + [1]}, "emissiveFactor": e,
                      "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10}} if any(e) else {}}
                     for a, e in materials], "extensionsUsed": ["KHR_materials_emissive_strength"]}
json.dump(doc, open(sys.argv[1], "w"))
PY
engine=/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb

# Ten engines (1,214,960 triangles): the engine's nodes copied ten times under roots placed 1.2 of
# its box apart in a 5 x 2 row, sharing its meshes and buffer (glTF instancing).
python3 - "$engine" "$work/engines.glb" <<'PY'
import json, struct, sys
data = open(sys.argv[1], "rb").read()
length = struct.unpack_from("<I", data, 12)[0]
doc = json.loads(data[20:20 + length])
binary = data[20 + length + 8:]
def multiply(a, b):  # column-major 4x4, as glTF stores them
    return [sum(a[k * 4 + r] * b[c * 4 + k] for k in range(4)) for c in range(4) for r in range(4)]
def local(node):  # the engine's nodes hold matrices or nothing
    return node.get("matrix", [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])
low, high = [float("inf")] * 3, [float("-inf")] * 3
def walk(index, parent):
    world = multiply(parent, local(doc["nodes"][index]))
    if "mesh" in doc["nodes"][index]:
        for primitive in doc["meshes"][doc["nodes"][index]["mesh"]]["primitives"]:
            box = doc["accessors"][primitive["attributes"]["POSITION"]]
            for corner in range(8):
                p = [(box["max"] if corner >> i & 1 else box["min"])[i] for i in range(3)]
                for i in range(3):
                    v = sum(world[c * 4 + i] * p[c] for c in range(3)) + world[12 + i]
                    low[i], high[i] = min(low[i], v), max(high[i], v)
    for child in doc["nodes"][index].get("children", []):
        walk(child, world)
roots = doc["scenes"][doc.get("scene", 0)]["nodes"]
for root in roots:
    walk(root, local({}))
size = [high[i] - low[i] for i in range(3)]
count = len(doc["nodes"])
nodes = []
for copy in range(10):
    for node in doc["nodes"]:
        node = dict(node)
        node.pop("camera", None)
        if "children" in node:
            node["children"] = [c + copy * count for c in node["children"]]
        nodes.append(node)
for copy in range(10):
    nodes.append({"translation": [1.2 * size[0] * (copy % 5), 0, 1.2 * size[2] * (copy // 5)],
                  "children": [r + copy * count for r in roots]})
doc["nodes"] = nodes
doc.pop("cameras", None)
doc["scenes"] = [{"nodes": list(range(10 * count, 10 * count + 10))}]
doc["scene"] = 0
text = json.dumps(doc).encode()
text += b" " * (-len(text) % 4)
binary += b"\0" * (-len(binary) % 4)
out = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(binary))
out += struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
open(sys.argv[2], "wb").write(out)
PY

rows=()
# run NAME PROBES COMMAND...: seconds and peak KiB of the whole process.
run() {
    local name=$1 probes=$2
    shift 2
    /usr/bin/time -f "%e %M" -o "$work/time" "$@" >/dev/null
    read -r seconds kib <"$work/time"
    rows+=("$name $probes $seconds $kib")
    awk -v name="$name" -v p="$probes" -v s="$seconds" -v k="$kib" \
        'BEGIN { r = s > 0 ? sprintf("%9.0f", p / s) : "        -"
                 printf "%-28s %6d probes %8.2f s %s probes/s  peak %7.1f MiB\n", name, p, s, r, k / 1024 }'
}
for grid in 10,10,10 25,20,20; do
    probes=$(( ${grid//,/*} ))
    run "gpu: cornell box" "$probes" "$build/shprobe" scene "$work/cornell.gltf" --grid "$grid" --face-size 32 \
        --bounces 0 --backend gpu --rays-per-texel 1 -q -o "$work/gpu.shpv"
    run "cpu: cornell box" "$probes" "$build/shprobe" scene "$work/cornell.gltf" --grid "$grid" --face-size 32 \
        --bounces 0 --backend cpu --rays-per-texel 1 -q -o "$work/cpu.shpv"
    run "reference: cornell box" "$probes" "$build/shprobe-reference" "$work/cornell.gltf" --grid "$grid" \
        --bounces 0 -q -o "$work/reference.shpv"
done
run "gpu: 2CylinderEngine" 1000 "$build/shprobe" scene "$engine" --grid 10,10,10 --face-size 32 --bounces 0 \
    --backend gpu --rays-per-texel 1 -q -o "$work/gpu.shpv"
run "cpu: 2CylinderEngine" 1000 "$build/shprobe" scene "$engine" --grid 10,10,10 --face-size 32 --bounces 0 \
    --backend cpu --rays-per-texel 1 -q -o "$work/cpu.shpv"
run "reference: 2CylinderEngine" 1000 "$build/shprobe-reference" "$engine" --grid 10,10,10 --bounces 0 -q \
    -o "$work/reference.shpv"
run "cpu: 10 x 2CylinderEngine" 1000 "$build/shprobe" scene "$work/engines.glb" --grid 10,10,10 --face-size 32 \
    --bounces 0 --backend cpu --rays-per-texel 1 -q -o "$work/cpu.shpv"
run "reference: 10 x 2CylinderEngine" 1000 "$build/shprobe-reference" "$work/engines.glb" --grid 10,10,10 \
    --bounces 0 -q -o "$work/reference.shpv"
for scene in "$work/cornell.gltf" "$engine"; do
    name=$(basename "$scene" | sed 's/\..*//')
    run "gpu, 1 bounce: $name" 64 "$build/shprobe" scene "$scene" --grid 4,4,4 --bounces 1 --backend gpu -q \
        -o "$work/gpu.shpv"
    for light in cache paths; do
        run "cpu, 1 bounce ($light): $name" 64 "$build/shprobe" scene "$scene" --grid 4,4,4 --bounces 1 \
            --backend cpu --bounce-light "$light" -q -o "$work/cpu.shpv"
    done
    run "reference, 1 bounce: $name" 64 "$build/shprobe-reference" "$scene" --grid 4,4,4 --bounces 1 -q \
        -o "$work/reference.shpv"
done
# Relighting a 32^3 volume at order 3 (scene/volume_bake.h), against reading its transfer's bytes in
# the same process: its transfer baked at faces 2^2, one ray a texel, bounce 0 (what relighting costs
# depends on the probes and the order alone).
run "cpu, transfer: cornell box" 32768 "$build/shprobe" scene "$work/cornell.gltf" --grid 32,32,32 \
    --face-size 2 --rays-per-texel 1 --bounces 0 --transfer -q -o "$work/transfer.shpv"
"$build/shprobe" relight "$work/transfer.shpv" --timings -o "$work/relit.shpv" | grep '^time'

# Transfer vectors per second: `shprobe transfer` (interreflected, 1 bounce, order 3, 64 rays per
# vertex and pass) on both backends on the same scenes, whole processes as above; a vector is one
# vertex's (every side's) transfer.
transferRows=()
for scene in "$work/cornell.gltf" "$engine"; do
    name=$(basename "$scene" | sed 's/\..*//')
    for backend in gpu cpu; do
        /usr/bin/time -f "%e %M" -o "$work/time" "$build/shprobe" transfer "$scene" --model interreflected \
            --bounces 1 --rays 64 --backend "$backend" -o "$work/transfer.glb" >"$work/transfer.txt"
        read -r seconds kib <"$work/time"
        vertices=$(awk '$1 == "vertices" {print $2}' "$work/transfer.txt")
        transferRows+=("$backend: transfer $name $vertices $seconds $kib")
        awk -v name="$backend: transfer $name" -v n="$vertices" -v s="$seconds" -v k="$kib" \
            'BEGIN { r = s > 0 ? sprintf("%9.0f", n / s) : "        -"
                     printf "%-28s %6d vectors %7.2f s %s transfer vectors/s  peak %7.1f MiB\n", name, n, s, r, k / 1024 }'
    done
done
# `shprobe transfer`'s shadowed rays against Embree's own rate on the same rays, and the GPU's
# hierarchy on the cores, in one process (shprobe-reference --transfer-rate).
"$build/shprobe-reference" "$engine" --transfer-rate 64

# Memory per probe: (peak at 10,000 - peak at 1,000) / 9,000, per program.
perProbe() {
    local small big
    small=$(printf '%s\n' "${rows[@]}" | awk -v n="$1" '$0 ~ n && $(NF-2) == 1000 {print $NF}' | head -1)
    big=$(printf '%s\n' "${rows[@]}" | awk -v n="$1" '$0 ~ n && $(NF-2) == 10000 {print $NF}' | head -1)
    awk -v b="$big" -v s="$small" 'BEGIN { print (b - s) * 1024 / 9000 }'
}
printf 'memory per probe: gpu %.0f bytes, cpu %.0f bytes, reference %.0f bytes\n' "$(perProbe 'gpu: cornell')" \
    "$(perProbe 'cpu: cornell')" "$(perProbe 'reference: cornell')"
if [ -n "$json" ]; then
    printf '%s\n' "${transferRows[@]}" >"$work/transfer_rows"
    printf '%s\n' "${rows[@]}" | python3 -c '
import json, sys
# GNU time counts hundredths: a process shorter than that has no rate (null).
def rate(count, seconds):
    return count / seconds if seconds > 0 else None
rows = []
for line in sys.stdin:
    *name, probes, seconds, kib = line.split()
    rows.append({"name": " ".join(name), "probes": int(probes), "seconds": float(seconds),
                 "probes_per_second": rate(int(probes), float(seconds)), "peak_kib": int(kib)})
transfer = []
for line in open(sys.argv[2]):
    *name, vectors, seconds, kib = line.split()
    transfer.append({"name": " ".join(name), "vectors": int(vectors), "seconds": float(seconds),
                     "transfer_vectors_per_second": rate(int(vectors), float(seconds)), "peak_kib": int(kib)})
json.dump({"face_size": 32, "bounces": 0, "rows": rows, "transfer_rows": transfer}, open(sys.argv[1], "w"),
          indent=1)' "$json" "$work/transfer_rows"
fi
