/// @file workloads.hpp
/// The operations `tether bench` measures per codec, workload (servo / sensor) and payload (demo / small /
/// large). `demo` is the demo's own operation (tether/demo/workload.hpp), so runs stay comparable with
/// `tether demo` and with earlier bench runs; `small` and `large` are the smallest and the largest operation
/// of the same kind that the virtual rover's images really execute, to show what the message size costs:
///
/// | codec | servo small | servo large | sensor small | sensor large |
/// |---|---|---|---|---|
/// | romi | `S[t,s]` -> `[0]` | `L[t,s,"32-char label"]` -> `[0,32]` (55-byte frame) | `A[ch]` -> `[0,v]` | `R` -> `[0,a0..a5]` |
/// | proxy | DigitalControl -> Ack | ServoControl (2-byte position) -> Ack | DigitalControl, PinState read back | ServoControl, PinState read back |
/// | elcano | `D{s}{a}` -> drive node's `S` | `X{n}{s}{b}{p}` -> segment node's `D` -> drive node's `S` | `G{n}{b}{p}` round the ring -> `S` | the same with 7-digit positions and `{r}` |
///
/// The proxy's sensor read is a read-back: the device reports `PinState` after every control (primary:
/// before its Ack; proxy-compat: in its ~50 ms state stream), and the operation ends when the report with
/// the commanded value arrives. A report with another value is a wrong answer. Every reply is checked.
#pragma once

#include <memory>
#include <string>

#include "tether/demo/workload.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"

namespace tether::bench {

/// Which operation a run measures (demo/workload.hpp).
using WorkloadKind = demo::WorkloadKind;
/// The size of the operation measured (demo/workload.hpp).
using Payload = demo::Payload;
using demo::to_string;

/// The operation of `kind` and `payload` on `device` (config: its entry in the rover's config). Null, with
/// `why` set, when the device cannot do it (a codec without it, a proxy config without the pin it needs).
std::unique_ptr<demo::Workload> make_bench_workload(const devices::RoverDevice& device,
                                                    const devices::DeviceConfig& config, WorkloadKind kind,
                                                    Payload payload, std::string& why);

}  // namespace tether::bench
