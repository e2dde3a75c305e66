#!/usr/bin/env bash
# Times selfcd's Rust examples at several thread counts and prints, per row,
# the time and a checksum of the output's bits: every checksum of a row must
# be the same at every thread count (deterministic output).
#
#   cargo build --release --examples -p selfcd
#   bash scripts/thread_scaling.sh [THREADS...]     (default: 1 2 4 8 16)
#
# BIN: the examples' directory (target/release/examples); DATA: the meshes
# (../shared/data). Rows: per frame (the default method on the peer script's
# four-frame wave, mean of frames 4-23), one-shot (best of 5), proximity per
# frame at d = 0.6 mean edges, the kept hierarchy's build (best of 3) and
# the paper's centre cloth at 101 x 101 vertices (first 60 steps).
set -euo pipefail
BIN=${BIN:-target/release/examples}
DATA=${DATA:-../shared/data}
THREADS=("$@")
[ ${#THREADS[@]} -gt 0 ] || THREADS=(1 2 4 8 16)

mean_frames() { # mean refit + traverse (ms) of "frame N:" lines, N >= 4
  awk '/^frame [0-9]+:/{n=$2+0; if(n>=4){s+=$4+$7; c++}} END{printf "%.2f", s/c}'
}
checksum() { awk '/checksum/{for (i = 1; i < NF; i++) if ($i == "checksum") print $(i + 1)}' | tail -1; }

row() { printf '%-34s %3s threads %10s ms  %s\n' "$1" "$2" "$3" "$4"; }

for t in "${THREADS[@]}"; do
  export RAYON_NUM_THREADS=$t
  for input in "$DATA/dress_on_body.obj" "$DATA/multilayer_skirt_on_body.obj" "200000 crumpled"; do
    name=$(basename "$input" .obj)
    # shellcheck disable=SC2086
    out=$(PROF_WAVE=1 PROF_EACH=1 "$BIN/prof" $input bvh-cones-contour 24)
    row "per frame $name" "$t" "$(mean_frames <<<"$out")" "$(checksum <<<"$out")"
    # shellcheck disable=SC2086
    out=$(PROF_ONESHOT=1 "$BIN/prof" $input bvh 5)
    row "one-shot $name" "$t" "$(awk '/one-shot best/{print $3}' <<<"$out")" "$(checksum <<<"$out")"
  done
  out=$(PROF_WAVE=1 PROF_EACH=1 "$BIN/prof" "$DATA/skirt_32k.obj" bvh-cones-contour 8 0.6)
  row "proximity per frame skirt_32k" "$t" "$(mean_frames <<<"$out")" "$(checksum <<<"$out")"
  out=$(PROF_BUILDS=3 "$BIN/prof" 200000 crumpled bvh-cones-contour 0)
  row "build crumpled 200k" "$t" "$(awk '/best build/{print $5}' <<<"$out")" "-"
  out=$("$BIN/cloth" center 101 60)
  row "cloth centre 101 (60 steps)" "$t" "$(awk '/mean step/{print $3}' <<<"$out")" "$(checksum <<<"$out")"
done
