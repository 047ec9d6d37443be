#!/bin/bash
# Speed of two builds of `xtask disparity`, interleaved on the same inputs: BEFORE AFTER [ROUNDS]
# (default 5). Per round and configuration, each build's `seconds:` (the median of --runs 9), on
# teddy (450x375x64, ../shared) and the 1282x1110x224 resize of benches/scripts/pairs.py
# ($PAIRS_OUT, default /tmp/parallax-pairs; run `SET=middlebury python3 -c 'import pairs;
# pairs.pairs()'` in benches/scripts first), two threads. Prints the load before and after.
# The block-matching rows give every option whose default changed with issue 47, so builds on
# either side of it compute the same maps (check with maps_identical.py); the SGM rows' maps
# changed with issue 47. ROWS="bm ssd" runs only the rows named.
set -e
B=$1; A=$2; ROUNDS=${3:-5}; P=${PAIRS_OUT:-/tmp/parallax-pairs}
SHARED=${PARALLAX_SHARED:-$(dirname "$0")/../../../shared}
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
cp "$SHARED/data/middlebury/teddy/imL.png" "$T/l450.png"; cp "$SHARED/data/middlebury/teddy/imR.png" "$T/r450.png"
cp "$P/l1282.png" "$P/r1282.png" "$T/"
uptime
for round in $(seq "$ROUNDS"); do
  for cfg in "bm:--prefilter xsobel --uniqueness 0 --lr-max-diff -1 --speckle-window 0 --texture 10 --block 9" \
             "sad32:--prefilter none --block 11 --uniqueness 5 --lr-max-diff 1 --speckle-window 100" \
             "ssd:--prefilter none --cost ssd --block 9 --uniqueness 15 --lr-max-diff 1 --speckle-window 100" \
             "sgm3:--method sgm --sgm-paths 3 --uniqueness 10 --lr-max-diff 1 --speckle-window 0 --texture 0" \
             "accurate:--method sgm --accurate"; do
    name=${cfg%%:*}; opts=${cfg#*:}
    case " ${ROWS:-bm sad32 ssd sgm3 accurate} " in *" $name "*) ;; *) continue ;; esac
    for pair in 450:64 1282:224; do
      w=${pair%%:*}; nd=${pair#*:}
      for tag in before after; do
        exe=$B; [ $tag = after ] && exe=$A
        # shellcheck disable=SC2086
        t=$("$exe" disparity --left "$T/l$w.png" --right "$T/r$w.png" --disparities "$nd" --out "$T/out-$tag" \
            --threads 2 --runs 9 $opts 2>&1 | grep "^seconds:" | cut -d" " -f2)
        echo "$round $name $w $tag $t"
      done
    done
  done
done
uptime
