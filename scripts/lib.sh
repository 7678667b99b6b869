# Shared by the measurement scripts: builds the release binary (or takes
# the one NERF_BIN names, to compare two builds), makes a scratch folder
# removed on exit, and appends result rows to docs/captures.csv labelled
# with the date, commit (NERF_COMMIT when NERF_BIN is given) and CPU.
given=${NERF_BIN:+$(realpath "$NERF_BIN")}
cd "$(dirname "$0")/.."
if [ -n "$given" ]; then
  bin=$given
else
  cargo build --release --quiet
  bin=target/release/nerf
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
csv=docs/captures.csv
[ -f "$csv" ] || echo "date,commit,cpu,capture,treatment,minutes,steps,psnr,ssim" > "$csv"
cpu=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//; s/,//g')
commit=${NERF_COMMIT:-$(git rev-parse --short HEAD)}

# steps RUN_DIR: training steps of the run's model.
steps() {
  "$bin" info "$1/model.nerf" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["trained"]["iterations"])'
}

# record CAPTURE TREATMENT MINUTES STEPS EVAL_JSON: appends one row and shows it.
record() {
  python3 - "$1" "$2" "$3" "$4" "$5" "$(date -u +%F)" "$commit" "$cpu" >> "$csv" <<'PY'
import json, sys
cap, name, minutes, steps, path, date, commit, cpu = sys.argv[1:]
e = json.load(open(path))
print(f"{date},{commit},{cpu},{cap},{name},{minutes},{steps},{e['psnr']:.2f},{e['ssim']:.4f}")
PY
  tail -1 "$csv" >&2
}
