#!/bin/bash
# The detail editor exercised in a real window by input replay (issue 13, "Must show"): under
# Xvfb at 1280×800, the viewer on the analytic planet with the editor open
# (GLOBE_VIEWER_EDITOR=1); xdotool drags the `hurst` slider, loads the `alpine` preset, saves
# the parameters, loads the `default` preset, loads the file back and saves it again (the two
# files must be equal), paints on the amplitude map and loads a missing file (a red line).
# A screenshot of the whole screen (panel and editor included) after each step goes to $OUT.
# Needs: xvfb, xdotool, x11-apps (xwd), python3; a built `globe` (GLOBE, default
# target/debug/globe). The pointer positions are those of the editor's default layout at
# 1280×800 (the window opens at the top right).
#   OUT=replay bash scripts/editor_replay.sh
set -eu
OUT=${OUT:-replay}
GLOBE=$(realpath "${GLOBE:-target/debug/globe}")
mkdir -p "$OUT"
cd "$OUT"
rm -f detail.json first.json again.json
export DISPLAY=${REPLAY_DISPLAY:-:77}
Xvfb "$DISPLAY" -screen 0 1280x800x24 > xvfb.log 2>&1 &
XVFB=$!
sleep 1
GLOBE_VIEWER_EDITOR=1 "$GLOBE" --dem analytic --scene aircraft > globe.log 2>&1 &
VIEWER=$!
trap 'kill $VIEWER 2>/dev/null; sleep 1; kill $XVFB 2>/dev/null' EXIT

shot() { # the whole screen as $1.png (xwd → PNG, 32-bit ZPixmap)
  xwd -root -silent > "$1.xwd"
  python3 - "$1.xwd" "$1.png" << 'EOF'
import struct, sys, zlib
d = open(sys.argv[1], 'rb').read()
h = struct.unpack('>25I', d[:100])
size, w, hgt, bpl, ncolors = h[0], h[4], h[5], h[12], h[19]
px = d[size + 12 * ncolors:]
raw = b''.join(b'\0' + bytes(v for x in range(w) for v in px[y * bpl + 4 * x:y * bpl + 4 * x + 3][::-1])
               for y in range(hgt))
def chunk(t, data):
    return struct.pack('>I', len(data)) + t + data + struct.pack('>I', zlib.crc32(t + data))
open(sys.argv[2], 'wb').write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, hgt, 8, 2, 0, 0, 0))
                              + chunk(b'IDAT', zlib.compress(raw, 6)) + chunk(b'IEND', b''))
EOF
  rm "$1.xwd"
  echo "[$SECONDS s] $1.png"
}
click() { xdotool mousemove "$1" "$2" click 1; }
typekeys() { for k in "$@"; do xdotool key "$k"; sleep 0.5; done; }
# Frames take ~0.5 s on lavapipe (debug build); a rebuild refills every level once.
SETTLE=${SETTLE:-8}

WIN=$(xdotool search --sync --name '^globe$' | head -1)
sleep 20
xdotool windowfocus --sync "$WIN"
shot 1-start
# 1. Drag the hurst slider's handle to the left (one rebuild, on release).
xdotool mousemove 1153 523; sleep 1; xdotool mousedown 1; sleep 1.5
for x in 1140 1125 1110 1095 1090; do xdotool mousemove $x 523; sleep 1; done
shot 2-slider-held
xdotool mouseup 1; sleep "$SETTLE"
shot 3-slider-released
# 2. The alpine preset (the status line moves what is below it down by 13 px from here on).
click 1083 51; sleep "$SETTLE"
shot 4-alpine
# 3. Save to detail.json (the default path), keep a copy.
click 1178 74; sleep 2
cp detail.json first.json
# 4. The default preset, then Load the file back and save it again: equal files.
click 1021 51; sleep "$SETTLE"
shot 5-default
click 1127 74; sleep "$SETTLE"
shot 6-loaded
rm detail.json; click 1178 74; sleep 2
cp detail.json again.json
cmp first.json again.json && echo "saved, loaded back and saved again: equal" | tee equal.txt
# 5. Paint around the view centre (lat 45.65, lon 10.65) on the amplitude map.
X=$((947 + (10 + 180) * 256 / 360)); Y=$((281 + (90 - 46) * 128 / 180))
xdotool mousemove $X $Y; sleep 0.7; xdotool mousedown 1; sleep 1
for d in 3 6 9 6 3 0; do xdotool mousemove $((X + d)) $((Y + d / 3)); sleep 0.8; done
xdotool mouseup 1; sleep "$SETTLE"
shot 7-painted
# 6. A file that does not exist: a red line, the detail in use stays.
click 1060 73; sleep 1.2; typekeys End BackSpace BackSpace BackSpace BackSpace BackSpace q period j s o n
click 1127 74; sleep 2
shot 8-missing-file
