#!/usr/bin/env bash
# Screenshots of the desktop workbench's main views under a virtual X server.
#
# Installs nothing. It needs (Debian/Ubuntu, see /work/shared/TOOLCHAIN.md):
#   apt-get install -y --no-install-recommends xvfb xauth x11-apps imagemagick libgl1 \
#     libglx-mesa0 libgl1-mesa-dri libx11-xcb1 libxcursor1 libxi6 libxkbcommon-x11-0
#
# Usage: scripts/screenshots.sh [OUT_DIR] [WAIT_S] [LOOP_WAIT_S]
#   OUT_DIR      where the PNGs go (default docs/screenshots)
#   WAIT_S       seconds to wait for the demo (chain, simulation, comparison) before the
#                picture is taken (default 25)
#   LOOP_WAIT_S  seconds to wait for the model-loop view, which also runs "Find missing
#                effect" after the demo (default 120)
#
# For each view (spectra, time, filter, compare, scf, model; or those in $VIEWS) it starts `twinscope --view VIEW`
# on the bundled demo inside `xvfb-run`, waits, grabs the root window with `xwd` and converts
# it with ImageMagick's `convert`. Settings go to a throw-away directory; they hold a fast
# missing-effect search (0.5 s fits, 5 evaluations per parameter, one sweep, three candidate
# effects) so the model-loop picture shows a ranking within LOOP_WAIT_S.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT="${1:-docs/screenshots}"
WAIT_S="${2:-25}"
LOOP_WAIT_S="${3:-120}"
mkdir -p "$OUT"
BIN=target/release/twinscope
[ -x "$BIN" ] || cargo build --release
CONVERT=/usr/bin/convert
[ -x "$CONVERT" ] || CONVERT=convert
for tool in xvfb-run xwd; do
  command -v "$tool" >/dev/null || { echo "screenshots.sh: $tool missing; see the apt-get line at the top of this script" >&2; exit 1; }
done
unset WAYLAND_DISPLAY
export XDG_CONFIG_HOME
XDG_CONFIG_HOME="$(mktemp -d)"
trap 'rm -rf "$XDG_CONFIG_HOME"' EXIT
mkdir -p "$XDG_CONFIG_HOME/twinscope"
cat > "$XDG_CONFIG_HOME/twinscope/settings.toml" <<'TOML'
loop_fit_duration_s = 0.5
loop_evaluations_per_parameter = 5
loop_sweeps = 1
loop_candidates = ["load_zone", "slip", "sensor_response"]
TOML
for view in ${VIEWS:-spectra time filter compare scf model}; do
  wait_s="$WAIT_S"
  extra=()
  if [ "$view" = model ]; then
    wait_s="$LOOP_WAIT_S"
    extra=(--find-missing-effect)
  fi
  xwd_file="$(mktemp --suffix=.xwd)"
  # One X server per view; the app runs in the background, the grab happens after WAIT_S.
  xvfb-run -a -s "-screen 0 1280x800x24" bash -c '
    bin="$1"; view="$2"; wait_s="$3"; out="$4"; shift 4
    "$bin" --view "$view" "$@" & pid=$!
    sleep "$wait_s"
    xwd -root -silent > "$out"
    kill "$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true
  ' _ "$BIN" "$view" "$wait_s" "$xwd_file" "${extra[@]}"
  "$CONVERT" "xwd:$xwd_file" "$OUT/$view.png"
  rm -f "$xwd_file"
  echo "screenshots.sh: $OUT/$view.png"
done
