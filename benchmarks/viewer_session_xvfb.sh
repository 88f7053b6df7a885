#!/bin/bash
# A simulator session driven like a user's, under a virtual display, from an empty kernel cache: the window opens
# after the warm-up; then a grasp, a switch to neo-Hookean and a grasp under it, a probe press and a scalpel stroke.
# Prints how many kernels were compiled after the window opened (0 is the target: no interaction waits on
# compilation) and leaves a screenshot of each step in OUT.
#   bash benchmarks/viewer_session_xvfb.sh [OUT]      (needs Xvfb, xdotool and ImageMagick's import: apt-get install
#                                                       xvfb xdotool imagemagick; the panel's places are for 1280x800)
set -euo pipefail
OUT=${1:-viewer_session}
mkdir -p "$OUT"
export NUMBA_CACHE_DIR=$(mktemp -d)
export DISPLAY=:${DISPLAY_NUMBER:-99}
Xvfb "$DISPLAY" -screen 0 1280x800x24 >/dev/null 2>&1 &
XVFB=$!
trap 'kill $XVFB 2>/dev/null; rm -rf "$NUMBA_CACHE_DIR"' EXIT
sleep 2
start=$(date +%s)
tissuesim view liver >"$OUT/view.log" 2>&1 &
VIEW=$!
until grep -q "^tools:" "$OUT/view.log" 2>/dev/null; do sleep 2; done     # the window's first line: warm-up done
sleep 5
echo "window open after $(( $(date +%s) - start )) s"
touch "$OUT/.open"
shot() { import -window root "$OUT/$1.png"; }
drag() {  # x0 y0 x1 y1 steps
  xdotool mousemove "$1" "$2"; sleep 0.3; xdotool mousedown 1
  for k in $(seq 1 "$5"); do
    xdotool mousemove $(( $1 + ($3 - $1) * k / $5 )) $(( $2 + ($4 - $2) * k / $5 )); sleep 0.08
  done
}
drag 500 330 500 250 15; sleep 1; shot 1_grasp; xdotool mouseup 1; sleep 0.5; xdotool key r; sleep 1
xdotool mousemove 1030 621 click 1; sleep 1; xdotool mousemove 1005 695 click 1; sleep 3     # strain: neo-hookean
drag 500 330 500 270 10; sleep 1.5; shot 2_grasp_neo_hookean; xdotool mouseup 1; sleep 0.5; xdotool key r; sleep 1
xdotool mousemove 970 129 click 1; sleep 1                                                     # the probe
drag 480 360 520 360 10; sleep 2; shot 3_probe; xdotool mouseup 1; sleep 1; xdotool key r; sleep 1
xdotool key s; sleep 0.5                                                                       # the scalpel
drag 380 335 620 335 30; sleep 1; shot 4_cut; xdotool mouseup 1; sleep 2
echo "kernels compiled after the window opened: $(find "$NUMBA_CACHE_DIR" -newer "$OUT/.open" -name '*.nbi' | wc -l)"
xdotool key q; wait $VIEW || true
