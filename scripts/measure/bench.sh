#!/usr/bin/env bash
# The renderer's cost per ray and per 8x8 tile (`cargo bench --bench
# per_ray`: random-weight paper, fast and features networks in f32, int16
# and int8, and a whole view of the shipped grid model), this core's
# multiply-accumulate ceilings (`cargo bench --bench peak`), one core each,
# and a training step with the gemm crate's products at the hidden layers'
# shapes (`cargo bench --bench train_step`; the step on every core).
# Appends one row per benchmark that ran to docs/bench.csv: date, commit,
# CPU, cores, criterion's group and function, the mean time per iteration
# in nanoseconds, and the elements per iteration (multiply-accumulates for
# per_ray, per_tile, peak and gemm; rays for frame/grid-model and
# train_step).
#
#   scripts/measure/bench.sh [BENCH...]     (default: per_ray peak train_step)
set -euo pipefail
benches=("$@")
[ ${#benches[@]} -gt 0 ] || benches=(per_ray peak train_step)
. "$(dirname "$0")/../lib/lib.sh"
out=docs/bench.csv
[ -f "$out" ] || echo "date,commit,cpu,cores,group,function,ns_per_iter,elements_per_iter" > "$out"
touch "$work/start"
cargo bench --quiet $(printf -- "--bench %s " "${benches[@]}") >&2
python3 - "$stamp" $(find target/criterion -path '*/new/benchmark.json' -newer "$work/start" | sort) <<'PY' |
import json, os, sys
stamp = sys.argv[1]
for path in sys.argv[2:]:
    b = json.load(open(path))
    e = json.load(open(os.path.join(os.path.dirname(path), "estimates.json")))
    n = (b.get("throughput") or {}).get("Elements", "")
    print(f"{stamp},{b['group_id']},{b['function_id']},{e['mean']['point_estimate']:.1f},{n}")
PY
  tee -a "$out" >&2
