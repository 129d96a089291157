// The operations `tether bench` measures per codec, workload and payload; see workloads.hpp.
#include "tether/bench/workloads.hpp"

#include <string>

namespace tether::bench {

std::unique_ptr<demo::Workload> make_bench_workload(const devices::RoverDevice& device,
                                                    const devices::DeviceConfig& config, WorkloadKind kind,
                                                    Payload payload, std::string& why) {
  return demo::make_workload(device, config, kind, payload, why);
}

}  // namespace tether::bench
