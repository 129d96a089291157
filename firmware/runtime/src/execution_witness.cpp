// The execution witness's recorder (tether/core/execution_witness.hpp): linked as an object library by the
// images that carry a witness, so the weak hook resolves to this definition.
#include "tether/core/execution_witness.hpp"

#include "tether/firmware/byte_ring.hpp"  // compiler_barrier

extern "C" {

/// The record the host reads (layout in execution_witness.hpp). C linkage: found by name in the ELF.
volatile uint8_t tether_execution_witness[tether::kWitnessRecordSize];

void tether_witness_executed(uint32_t key) {
  const uint8_t count = tether_execution_witness[tether::kWitnessExecutedOffset];
  volatile uint8_t* slot =
      &tether_execution_witness[tether::kWitnessLogOffset + 4u * (count % tether::kWitnessLogSize)];
  for (uint8_t i = 0; i < 4; ++i) slot[i] = static_cast<uint8_t>(key >> (8u * i));
  tether::firmware::compiler_barrier();  // the slot is complete before the count makes it visible
  tether_execution_witness[tether::kWitnessExecutedOffset] = static_cast<uint8_t>(count + 1u);
}

}  // extern "C"
