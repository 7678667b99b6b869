#!/usr/bin/env bash
# Memory an embedding program plans for, per target: the stack each
# nerf-infer call needs beyond its caller's frame (decoding a model,
# making a renderer, rendering a tile), found by painting the stack in the
# Cortex-M firmware under QEMU (examples/cortex-m: its int8 and int16
# models, ScratchFixed<4> in a static), at opt-level "s" and 3, as shipped
# and with nerf-infer's default features; and the sizes of the values it
# keeps (Model, RendererFixed, the scratches) there and on the host.
#
#   scripts/check/stack_table.sh           prints the table (markdown)
#   scripts/check/stack_table.sh --check   fails if a figure exceeds the one in nerf-infer/STACK.md
#
# QEMU's figures do not vary from run to run: the same build paints the
# same words.
set -euo pipefail
cd "$(dirname "$0")/../.."
check=0
[ "${1:-}" = "--check" ] && check=1
if ! command -v qemu-system-arm >/dev/null; then
    echo "installing qemu-system-arm" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq qemu-system-arm >/dev/null
fi
rows=()
# target, opt-level, nerf-infer features beyond the firmware's (none: the
# shipped models have neither grid; with both, the lm3s6965's 256 KiB of
# flash does not hold the code at opt-level 3 beside the two models)
configs=("thumbv7m-none-eabi s -" "thumbv7m-none-eabi 3 -" "thumbv7em-none-eabihf s -" "thumbv7em-none-eabihf 3 -"
    "thumbv7em-none-eabihf s feature-grid,proposal" "thumbv7em-none-eabihf 3 feature-grid,proposal")
for config in "${configs[@]}"; do
    read -r target opt features <<<"$config"
    flags=(); name="$target opt-level $opt"
    if [ "$features" != - ]; then flags=(--features "${features//,/ }"); name="$name, $features"; fi
    if ! out=$(cd examples/cortex-m && CARGO_PROFILE_RELEASE_OPT_LEVEL=$opt timeout 600 \
        cargo run --quiet --release --target "$target" "${flags[@]}" 2>&1) || ! grep -q "^PASS" <<<"$out"; then
        echo "$name: the firmware failed" >&2; echo "$out" >&2; exit 1
    fi
    rows+=("$name|$(grep '^stack:' <<<"$out")|$(grep '^sizes:' <<<"$out")")
done
host=$(cargo run --quiet -p nerf-infer --release --example sizes)
rows+=("x86_64 (host)|stack: decode=- renderer=- render_tile=- high_water=-|$host")
table=$(python3 - "${rows[@]}" <<'PY'
import sys
keys = ["decode", "renderer", "render_tile", "high_water"]
sizes = ["Model", "RendererFixed", "ScratchFixed1", "ScratchFixed4", "ScratchFixed8", "ScratchF32_1", "ScratchF32_8"]
print("| target | decode | renderer | render_tile | firmware high-water | " + " | ".join(sizes) + " |")
print("|---|" + "--:|" * (len(keys) + len(sizes)))
for row in sys.argv[1:]:
    name, stack, size = row.split("|")
    kv = dict(w.split("=") for w in (stack + " " + size).split() if "=" in w)
    print(f"| {name} | " + " | ".join(kv[k] for k in keys + sizes) + " |")
PY
)
if [ $check = 0 ]; then
    echo "$table"
    exit 0
fi
python3 - nerf-infer/STACK.md <<PY
import sys
def rows(text):
    out = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) > 2 and cells[0] and not cells[0].startswith(("target", "---")):
            out[cells[0]] = cells[1:]
    return out
head = None
for line in open(sys.argv[1]):
    if line.startswith("| target |"):
        head = [c.strip() for c in line.strip().strip("|").split("|")][1:]
documented = rows(open(sys.argv[1]).read())
measured = rows("""$table""")
bad = 0
for name, vals in measured.items():
    if name not in documented:
        print(f"{name}: not in {sys.argv[1]}"); bad += 1; continue
    for col, m, d in zip(head, vals, documented[name]):
        if m != "-" and int(m) > int(d):
            print(f"{name}: {col} {m} bytes, documented {d}"); bad += 1
print(f"stack table: {len(measured)} rows checked against {sys.argv[1]}, {bad} figures past the documented ones")
sys.exit(1 if bad else 0)
PY
