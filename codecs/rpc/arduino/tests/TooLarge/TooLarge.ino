// The sketch of tests/TooLarge/too_large.proto: its build stops at the library's RAM check.
#include <BigRpc.h>

tether::rpc::Status Big_Get(const big_Query& query, big_Report& report) {
  (void)query;
  report.samples_count = 0;
  return tether::rpc::Status::ok();
}

BigRpc device(Serial);

void setup() {
  Serial.begin(115200);
  device.begin();
}

void loop() { device.poll(); }
