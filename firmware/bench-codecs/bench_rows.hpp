/// @file bench_rows.hpp
/// The rows of the AVR cycle report, shared by the bench-codecs image (which marks each operation by
/// writing its row id to GPIOR0 before it and 0 after it) and benchmarks/avr_cycle_report.cpp (which
/// watches GPIOR0 on the virtual Uno and takes the cycles between the two writes). One list, so ids and
/// names cannot drift apart; GPIOR0 carries any number of rows (the old one-pin-per-row scheme had 20).
#pragma once

#include <stdint.h>

namespace tether_bench {

/// Row ids (1..kRowCount-1; 0 ends a measurement). Append new rows before kRowCount.
enum Row : uint8_t {
  kBaseline = 1,  ///< an empty measurement: the marker writes' own cost, removed from every row
  kRomiDecodeParse,
  kRomiEncodeResponse,
  kProxyDecode12,
  kProxyEncode12,
  kCrc16,
  kCrc8,
  kElcanoReadDriveB,
  kElcanoReadDriveD,
  kElcanoReadSegmentB,
  kElcanoReadSegmentD,
  kElcanoWriteDriveB,
  kElcanoWriteDriveD,
  kElcanoWriteSegmentB,
  kElcanoWriteSegmentD,
  kElcanoRingForwardB,
  kElcanoRingForwardD,
  kElcanoRingCaptureB,
  kRomiRequestA,
  kRomiRequestE,
  kRomiRequestC,
  kRomiRequestD,
  kProxyEncode32,
  kProxyDecode32,
  kRowCount
};

#ifndef __AVR__
/// What the report prints for a row: `key` names it in the JSON, `what` in the table.
struct RowInfo {
  Row id;
  const char* key;
  const char* what;
};

/// Every row but the baseline, in report order.
inline constexpr RowInfo kRows[] = {
    {kRomiRequestA, "romi.request.a", "Romi: #a:<id><crc> in -> #a[0] out (RomiSerial)"},
    {kRomiRequestE, "romi.request.e", "Romi: #e in -> #e[0,1,2] out (RomiSerial)"},
    {kRomiRequestC, "romi.request.c", "Romi: #c[1000,-2000] in -> #c[0] out (RomiSerial)"},
    {kRomiRequestD, "romi.request.d", "Romi: #d[\"Hello there\"] in -> #d[0] out"},
    {kRomiDecodeParse, "romi.decode_parse", "Romi: decode + parse request #s[1234,-567]"},
    {kRomiEncodeResponse, "romi.encode_response", "Romi: encode response #s[0,667]"},
    {kProxyEncode12, "proxy.encode.12", "proxy: encode frame, 12 B payload (CRC-16)"},
    {kProxyDecode12, "proxy.decode.12", "proxy: decode frame, 12 B payload (CRC-16)"},
    {kProxyEncode32, "proxy.encode.32", "proxy: encode frame, 32 B payload (CRC-16)"},
    {kProxyDecode32, "proxy.decode.32", "proxy: decode frame, 32 B payload (CRC-16)"},
    {kCrc16, "crc16.64", "CRC-16/MCRF4XX over 64 bytes"},
    {kCrc8, "crc8.64", "CRC-8/SMBUS over 64 bytes"},
    {kElcanoReadDriveB, "elcano.b.read.drive", "Elcano B: read drive D{s 50}{a 25}"},
    {kElcanoReadDriveD, "elcano.d.read.drive", "Elcano D: read drive D{s50}{a25}74"},
    {kElcanoReadSegmentB, "elcano.b.read.segment", "Elcano B: read segment X{n 4}...{p 3200,-64000}"},
    {kElcanoReadSegmentD, "elcano.d.read.segment", "Elcano D: read segment X{n4}...{q-64000}243"},
    {kElcanoWriteDriveB, "elcano.b.write.drive", "Elcano B: write drive"},
    {kElcanoWriteDriveD, "elcano.d.write.drive", "Elcano D: write drive"},
    {kElcanoWriteSegmentB, "elcano.b.write.segment", "Elcano B: write segment"},
    {kElcanoWriteSegmentD, "elcano.d.write.segment", "Elcano D: write segment"},
    {kElcanoRingForwardB, "elcano.b.ring.forward", "Elcano B: RingNode feed + forward drive"},
    {kElcanoRingForwardD, "elcano.d.ring.forward", "Elcano D: RingNode feed + forward drive"},
    {kElcanoRingCaptureB, "elcano.b.ring.capture", "Elcano B: RingNode feed + capture drive"},
};
#endif

}  // namespace tether_bench
