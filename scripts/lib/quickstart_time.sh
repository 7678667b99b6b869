# Shared by scripts/check/plain_build.sh and scripts/measure/block_sizes.sh: times a
# build of examples/quickstart.
#
# fastest_ray BIN MODEL SIZE DIR [TRIES]: runs `BIN MODEL SIZE` in DIR
# (where it writes view.ppm) TRIES times (default 2); sets `best` to the
# fewest µs per ray and `kernels` to the kernels it reported.
fastest_ray() {
  local bin=$1 model=$2 size=$3 dir=$4 tries=${5:-2} line us
  best=""
  for _ in $(seq "$tries"); do
    line=$(cd "$dir" && "$bin" "$model" "$size")
    us=$(sed -n 's/.* \([0-9.]*\) µs per ray.*/\1/p' <<<"$line")
    best=$(python3 -c "import sys; v=[float(x) for x in sys.argv[1:] if x]; print(min(v))" "$us" "$best")
  done
  kernels=$(sed -n 's/.*(\(.*\) kernels).*/\1/p' <<<"$line")
}
