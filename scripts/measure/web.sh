#!/usr/bin/env bash
# The browser viewer's figures for one model: writes its page with
# `nerf web`, serves it on 127.0.0.1, opens `index.html?check=1` in headless
# Chromium and prints the page's JSON (CRC-32 of the first orbit frame at
# 64x64, µs per ray of that frame without early termination, and the
# milliseconds of one 100x100 frame as the viewer draws it, early
# termination at 1e-3: over its workers, one per core, and on one thread;
# and frames per second of ten 200x200 frames drawn whole as the view
# orbits, `&orbit=10`), then the CRC-32 of `nerf render --orbit 1 --size
# 64`. Appends a row to docs/web.csv: date, commit, CPU, cores, Chromium's
# version, LABEL, whether the two CRCs agree, µs per ray, workers, the two
# frame times and the orbit's frames per second.
#
#   scripts/measure/web.sh [MODEL] [LABEL]      (default: models/scene_int8.nerf)
#   scripts/measure/web.sh --lego DATA_ROOT     the default trained 10 minutes on lego
#                                               at 100x100, exported to int8
set -euo pipefail
lego=""
if [ "${1:-}" = "--lego" ]; then
  lego=$(realpath "${2:?--lego needs the folder that holds lego/}")
  model="" label="lego int8 (the default, 10 min at 100×100)"
else
  model=$(realpath "${1:-models/scene_int8.nerf}")
  label=${2:-$(basename "$model")}
fi
. "$(dirname "$0")/../lib/lib.sh"
if [ -n "$lego" ]; then
  "$bin" train --data "$lego/lego" --downscale 8 --minutes 10 --val-views 0 --out "$work/lego" >&2
  "$bin" export "$work/lego/model.nerf" --bits 8 --out "$work/lego/int8.nerf" >&2
  model="$work/lego/int8.nerf"
fi
command -v chromium >/dev/null || { echo "needs chromium (apt-get install chromium)" >&2; exit 1; }
command -v python3 >/dev/null || { echo "needs python3 (its http.server)" >&2; exit 1; }
port=$((20000 + RANDOM % 20000))
python3 -m http.server "$port" --bind 127.0.0.1 -d "$work/page" >/dev/null 2>&1 &
server=$!
trap 'kill $server 2>/dev/null; rm -rf "$work"' EXIT
"$bin" web "$model" --out "$work/page" 2>/dev/null
sleep 1
# Chromium keeps running after the page reports: its log is read until the
# line appears (or 300 s pass), then it is stopped
timeout 300 chromium --headless --no-sandbox --disable-gpu --enable-logging=stderr --v=0 \
  --user-data-dir="$work/profile" "http://127.0.0.1:$port/index.html?check=1&orbit=10" >"$work/chromium.log" 2>&1 &
chrome=$!
page=""
while [ -z "$page" ] && kill -0 "$chrome" 2>/dev/null; do
  sleep 0.5
  page=$(grep -m1 -o 'nerf-check {[^}]*}' "$work/chromium.log" | sed 's/^nerf-check //' || true)
done
kill "$chrome" 2>/dev/null || true
wait "$chrome" 2>/dev/null || true
echo "$page"
[ -n "$page" ] || { echo "the page reported nothing" >&2; exit 1; }
"$bin" render "$model" --orbit 1 --size 64 --out "$work/host" >/dev/null 2>&1
host=$(python3 - "$work/host" <<'PY'
import os, sys, zlib, struct
d = sys.argv[1]
png = open(os.path.join(d, [f for f in os.listdir(d) if f.endswith("_000.png")][0]), "rb").read()
# 8-bit RGB PNG: inflate the IDAT stream and undo each row's filter
pos, idat, w, h = 8, b"", 0, 0
while pos < len(png):
    n, kind = struct.unpack(">I4s", png[pos:pos + 8])
    data = png[pos + 8:pos + 8 + n]
    if kind == b"IHDR":
        w, h = struct.unpack(">II", data[:8])
    elif kind == b"IDAT":
        idat += data
    pos += 12 + n
raw, stride, out, prev = zlib.decompress(idat), 3 * w, bytearray(), bytearray(3 * w)
for y in range(h):
    f, row = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
    for i in range(stride):
        a = row[i - 3] if i >= 3 else 0
        b, c = prev[i], (prev[i - 3] if i >= 3 else 0)
        p = a + b - c
        pred = [0, a, b, (a + b) // 2, a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else (b if abs(p - b) <= abs(p - c) else c)][f]
        row[i] = (row[i] + pred) & 0xFF
    out += row
    prev = row
print('{"host_crc32": %d}' % zlib.crc32(bytes(out)))
PY
)
echo "$host"
out=docs/web.csv
[ -f "$out" ] || echo "date,commit,cpu,cores,browser,model,crc_matches_host,us_per_ray,workers,frame_ms_100,frame_ms_100_one_thread,orbit_fps_200" > "$out"
browser=$(chromium --version 2>/dev/null | grep -o '[0-9][0-9.]*' | head -1)
python3 - "$stamp" "$browser" "$label" "$page" "$host" >> "$out" <<'PY'
import csv, json, sys
stamp, browser, label, page, host = sys.argv[1:]
p, h = json.loads(page), json.loads(host)
same = "yes" if p["crc32"] == h["host_crc32"] else "no"
csv.writer(sys.stdout, lineterminator="\n").writerow(stamp.split(",") + [
    f"Chromium {browser}", label, same, f"{p['us_per_ray']:.1f}", p["workers"], f"{p['frame_ms_100']:.1f}",
    f"{p['frame_ms_100_one_thread']:.1f}", f"{p['orbit_fps_200']:.1f}"])
PY
tail -1 "$out" >&2
