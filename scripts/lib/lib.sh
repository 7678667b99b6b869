# Shared by the measurement scripts: builds the release binary (or takes
# the one NERF_BIN names, to compare two builds), makes a scratch folder
# removed on exit, and appends result rows to docs/captures.csv labelled
# with the date, commit (NERF_COMMIT when NERF_BIN is given), CPU model and
# core count (`$stamp`, the first four columns of every results CSV).
given=${NERF_BIN:+$(realpath "$NERF_BIN")}
cd "$(dirname "$0")/../.."
if [ -n "$given" ]; then
  bin=$given
else
  cargo build --release --quiet
  bin=target/release/nerf
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
csv=docs/captures.csv
[ -f "$csv" ] || echo "date,commit,cpu,cores,capture,treatment,minutes,steps,psnr,ssim" > "$csv"
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//; s/,//g')
commit=${NERF_COMMIT:-$(git rev-parse --short HEAD)}
cores=$(nproc)
stamp="$(date -u +%F),$commit,$cpu,$cores"

# steps RUN_DIR: training steps of the run's model.
steps() {
  "$bin" info "$1/model.nerf" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["trained"]["iterations"])'
}

# record CAPTURE TREATMENT MINUTES STEPS EVAL_JSON: appends one row and shows it.
record() {
  python3 - "$1" "$2" "$3" "$4" "$5" "$stamp" >> "$csv" <<'PY'
import json, sys
cap, name, minutes, steps, path, stamp = sys.argv[1:]
e = json.load(open(path))
print(f"{stamp},{cap},{name},{minutes},{steps},{e['psnr']:.2f},{e['ssim']:.4f}")
PY
  tail -1 "$csv" >&2
}

# valgrind_bin: checks valgrind is installed and sets `bin` to a build for
# x86-64-v3 (AVX2; valgrind cannot run AVX-512): the one $given_v3 names
# (a script's realpath of NERF_BIN_V3), else target/v3's, built here.
valgrind_bin() {
  command -v valgrind >/dev/null || { echo "needs valgrind (apt-get install valgrind)" >&2; exit 1; }
  if [ -n "${given_v3:-}" ]; then
    bin=$given_v3
  else
    RUSTFLAGS="-C target-cpu=x86-64-v3" cargo build --release --quiet --bin nerf --target-dir target/v3
    bin=target/v3/release/nerf
  fi
}

# render_instructions OUT BIN MODEL EVAL_FLAGS...: runs `BIN eval MODEL
# EVAL_FLAGS...` under callgrind (OUT.cg), counting `render_view` and what
# it calls; writes eval's JSON to OUT.json and prints the instruction total.
render_instructions() {
  local out=$1 b=$2; shift 2
  valgrind --tool=callgrind --callgrind-out-file="$out.cg" --toggle-collect='*render_view*' "$b" eval "$@" \
    > "$out.json" 2>/dev/null
  # awk reads to the end (grep -m1 would stop the pipe early and fail it under pipefail)
  callgrind_annotate "$out.cg" 2>/dev/null | awk '/PROGRAM TOTALS/ && !n {gsub(",", "", $1); print $1; n = 1}'
}

# side_by_side STEPS NAME_A DATA_A NAME_B DATA_B: trains both captures STEPS
# steps at 1/8 size on one thread each at once (seed 0) into $work/NAME and
# scores each on its held-out views ($work/NAME/eval.json); shows a failed
# run's log and stops.
side_by_side() {
  local n=$1
  one() { # name data
    "$bin" train --data "$2" --downscale 8 --iters "$n" --threads 1 --seed 0 --out "$work/$1" > "$work/$1.log" 2>&1
    "$bin" eval "$work/$1/model.nerf" --data "$2" --split val --threads 1 > "$work/$1/eval.json"
  }
  one "$2" "$3" &
  local a=$!
  one "$4" "$5" &
  local b=$!
  wait $a || { cat "$work/$2.log" >&2; exit 1; }
  wait $b || { cat "$work/$4.log" >&2; exit 1; }
}

# builtin_capture: `data` named `room` or `llff` becomes that built-in
# capture of `nerf scene --size 64` (written to $work), trained at full
# size; any other folder is trained at 1/8 size. Sets `data` and `downscale`.
builtin_capture() {
  downscale=8
  if [ "$data" = room ] || [ "$data" = llff ]; then
    "$bin" scene --out "$work/scene" --size 64 >&2
    data=$work/scene/$data
    downscale=1
  fi
}
