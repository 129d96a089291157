#!/bin/sh
# Assembles the Romi device library as an Arduino library folder (1.5 format: library.properties, src/,
# examples/) from the Tether tree, so the Arduino IDE or arduino-cli can build sketches with it.
#
#   firmware/romi/arduino/make-arduino-library.sh ~/Arduino/libraries     # -> ~/Arduino/libraries/TetherRomi
#
# What goes into src/ (everything the device needs, nothing host- or runtime-specific):
#   - the device library's headers (RomiSerial.h & co., tether/romi/device/...) and sources, with the
#     Arduino clock (src/clock_arduino.cpp) instead of the Tether runtime's;
#   - the portable Romi codec (codecs/romi: headers, sources);
#   - the portable core (core/include; status.cpp and the avr-libc CRC back end).
# Re-run it after updating the tree: it replaces the TetherRomi folder.
set -eu

if [ $# -ne 1 ]; then
  echo "usage: $0 <arduino libraries directory>" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
out="$1/TetherRomi"

rm -rf "$out"
mkdir -p "$out/src/tether_sources"
cp "$here/library.properties" "$out/"
cp -R "$here/examples" "$out/"

# Headers: include paths are relative to src/ (the Arduino builder puts src/ on the include path).
cp -R "$root/firmware/romi/include/." "$out/src/"
cp -R "$root/core/include/tether/core" "$out/src/tether/"
cp -R "$root/codecs/romi/include/tether/romi/." "$out/src/tether/romi/"

# Sources: compiled recursively from src/ by the Arduino builder.
cp "$root/firmware/romi/src/romi_serial.cpp" \
   "$root/firmware/romi/src/array_text.cpp" \
   "$root/firmware/romi/src/clock_arduino.cpp" \
   "$root/codecs/romi/src/errors.cpp" \
   "$root/codecs/romi/src/encoder.cpp" \
   "$root/codecs/romi/src/request_parser.cpp" \
   "$root/core/src/status.cpp" \
   "$root/core/src/crc_avr_libc.cpp" \
   "$out/src/tether_sources/"

echo "Arduino library written to $out"
