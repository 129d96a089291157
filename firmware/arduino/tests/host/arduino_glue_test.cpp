// The Arduino libraries' glue on the host, over a fake Arduino core (fake-core/: Print, Stream and a
// HardwareSerial with the AVR core's members over fake UART registers): the runs read from and written to
// the core's rings (TetherArduinoStream.h), TetherRomi's ArduinoSerial under a RomiSerial, TetherElcano's
// ParseState, and the Stream paths that only have available()/read().
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ArduinoSerial.h"
#include "ElcanoSerial.h"
#include "RomiSerial.h"
#include "fake_core.hpp"
#include "tether/romi/encoder.hpp"

namespace {

using tether::arduino::read_run;
using tether::arduino::rx_consume;
using tether::arduino::rx_run;
using tether::arduino::write_all;

std::vector<uint8_t> bytes_of(const std::string& text) { return std::vector<uint8_t>(text.begin(), text.end()); }

// A HardwareSerial on its fake UART, whose wire starts empty.
struct Port {
  Port() { fake_core::wire.clear(); }
  void receive(const std::string& text) {
    for (const char c : text) serial._rx_complete_irq(static_cast<uint8_t>(c));
  }
  // Another byte (not recorded) is in the data register: the next ones queue.
  void busy() { uart.ucsra = static_cast<uint8_t>(uart.ucsra & ~(_BV(UDRE0) | _BV(TXC0))); }
  std::string sent() {
    fake_core::transmit(serial, uart);
    return std::string(fake_core::wire.begin(), fake_core::wire.end());
  }
  FakeUart uart;
  HardwareSerial serial{uart};
};

// --- TetherArduinoStream.h on the core's rings -----------------------------------------------------------

TEST(SerialRings, ALoneByteIsTakenAndFreed) {
  Port port;
  port.receive("x");
  uint8_t bytes[16];
  EXPECT_EQ(read_run(port.serial, bytes, sizeof bytes), 1);
  EXPECT_EQ(bytes[0], 'x');
  EXPECT_EQ(port.serial.available(), 0);
  EXPECT_EQ(read_run(port.serial, bytes, sizeof bytes), 0);
}

TEST(SerialRings, ARunAcrossTheRingsEndComesInOrderUpToTheCapacity) {
  Port port;
  port.serial.reset_rings(60, 0);  // 4 bytes to the end, then 6 from the start
  port.receive("0123456789");
  uint8_t bytes[16];
  ASSERT_EQ(read_run(port.serial, bytes, 7), 7);
  EXPECT_EQ(std::string(bytes, bytes + 7), "0123456");
  EXPECT_EQ(port.serial.rx_tail(), 3);
  ASSERT_EQ(read_run(port.serial, bytes, sizeof bytes), 3);
  EXPECT_EQ(std::string(bytes, bytes + 3), "789");
  EXPECT_EQ(port.serial.available(), 0);
}

TEST(SerialRings, InPlaceRunsEndAtTheRingsEndAndConsumeFreesWhatWasUsed) {
  Port port;
  port.serial.reset_rings(60, 0);
  port.receive("0123456789");
  const uint8_t* data = nullptr;
  ASSERT_EQ(rx_run(port.serial, data), 4);
  EXPECT_EQ(std::string(data, data + 4), "0123");
  rx_consume(port.serial, 3);  // the device used three
  ASSERT_EQ(rx_run(port.serial, data), 1);
  EXPECT_EQ(*data, '3');
  rx_consume(port.serial, 1);
  EXPECT_EQ(port.serial.rx_tail(), 0);
  ASSERT_EQ(rx_run(port.serial, data), 6);
  EXPECT_EQ(std::string(data, data + 6), "456789");
  rx_consume(port.serial, 6);
  EXPECT_EQ(rx_run(port.serial, data), 0);
}

TEST(SerialRings, AnIdleUartTakesTheFirstByteAtOnceAndClearsTxc) {
  Port port;
  const std::vector<uint8_t> reply = bytes_of("#a[0]");
  write_all(port.serial, reply.data(), 1);
  EXPECT_EQ(port.uart.udr, '#');  // into the data register, no interrupt
  EXPECT_NE(port.uart.ucsra & _BV(TXC0), 0u);
  EXPECT_EQ(port.serial.tx_queued(), 0);
  EXPECT_TRUE(port.serial.written());  // flush() waits for it
  write_all(port.serial, reply.data() + 1, reply.size() - 1);
  EXPECT_EQ(port.serial.tx_queued(), 4);
  EXPECT_NE(port.uart.ucsrb & _BV(UDRIE0), 0u);  // published with the interrupt enabled
  EXPECT_EQ(port.sent(), "#a[0]");
  EXPECT_EQ(port.uart.ucsrb & _BV(UDRIE0), 0u);
}

TEST(SerialRings, QueuedBytesWrapRoundTheRingInOrder) {
  Port port;
  port.serial.reset_rings(0, 60);
  port.busy();
  const std::vector<uint8_t> text = bytes_of("0123456789");
  write_all(port.serial, text.data(), text.size());
  EXPECT_EQ(port.serial.tx_queued(), 10);
  EXPECT_EQ(port.sent(), "0123456789");
}

TEST(SerialRings, AFullRingHandsTheRestToTheCoresWriteWhichWaits) {
  Port port;
  port.busy();
  std::string text;
  for (int i = 0; i < 100; ++i) text += static_cast<char>('A' + i % 26);
  const std::vector<uint8_t> bytes = bytes_of(text);
  write_all(port.serial, bytes.data(), bytes.size());
  // 63 queued at once (one slot stays free); the fake core's write() made room by sending one at a time
  // (the byte of busy() first, unrecorded).
  EXPECT_EQ(port.serial.tx_queued(), 63);
  EXPECT_EQ(fake_core::wire.size(), 36u);
  EXPECT_EQ(port.sent(), text);
}

// A Stream with only available() and read(), counting the calls.
class CountingStream : public Stream {
 public:
  explicit CountingStream(const std::string& input) : input_(input) {}
  int available() override {
    ++available_calls;
    return static_cast<int>(input_.size() - next_);
  }
  int read() override {
    ++read_calls;
    return next_ < input_.size() ? static_cast<uint8_t>(input_[next_++]) : -1;
  }
  int peek() override { return next_ < input_.size() ? static_cast<uint8_t>(input_[next_]) : -1; }
  size_t write(uint8_t byte) override {
    output += static_cast<char>(byte);
    return 1;
  }
  int availableForWrite() override { return 64; }
  using Print::write;
  int available_calls = 0;
  int read_calls = 0;
  std::string output;

 private:
  std::string input_;
  size_t next_ = 0;
};

TEST(StreamRuns, OneAvailablePerRunThenTheBytesItCounted) {
  CountingStream stream("0123456789");
  uint8_t bytes[16];
  ASSERT_EQ(read_run(stream, bytes, 4), 4);
  EXPECT_EQ(stream.available_calls, 1);
  EXPECT_EQ(stream.read_calls, 4);
  ASSERT_EQ(read_run(stream, bytes, sizeof bytes), 6);
  EXPECT_EQ(std::string(bytes, bytes + 6), "456789");
  EXPECT_EQ(stream.available_calls, 2);
  EXPECT_EQ(stream.read_calls, 10);
}

// --- TetherRomi: ArduinoSerial under a RomiSerial ---------------------------------------------------------

void ok(romiserial::IRomiSerial* romi, int16_t*, const char*) { romi->send_ok(); }
const romiserial::MessageHandler kHandlers[] = {{'a', 0, false, ok}};

std::string request(const char* payload, uint8_t id) {
  uint8_t frame[64];
  const size_t size =
      tether::romi::encode_request(tether::ByteView::from_chars(payload, strlen(payload)), id, frame).value();
  return std::string(frame, frame + size);
}

std::string response(char opcode, const char* body, uint8_t id) {
  uint8_t frame[64];
  const size_t size =
      tether::romi::encode_response(opcode, tether::ByteView::from_chars(body, strlen(body)), id, frame).value();
  return std::string(frame, frame + size);
}

TEST(ArduinoSerialOnHardwareSerial, ARequestInTheRingIsAnsweredThroughTheRing) {
  Port port;
  romiserial::ArduinoSerial serial(port.serial);  // the HardwareSerial constructor: the rings' path
  romiserial::RomiSerial romi(serial, serial, kHandlers, 1);
  port.serial.reset_rings(58, 62);  // the request and the reply both wrap round their rings
  port.receive(request("a", 7));
  port.busy();  // the UART still sends something: the whole reply is queued
  romi.handle_input();
  EXPECT_EQ(port.serial.available(), 0);
  EXPECT_EQ(port.sent(), response('a', "[0]", 7));
}

// ArduinoSerial::write_all queues a run the ring has room for itself (to the ring's end, then from its
// start) and hands one that must wait to the core's write(): every ring position, with the ring holding
// nothing, a little, or nearly all of its 63 bytes already, and runs that fit, fill it or exceed it.
TEST(ArduinoSerialOnHardwareSerial, RepliesAreQueuedInOrderAtEveryRingPosition) {
  for (uint8_t start = 0; start < SERIAL_TX_BUFFER_SIZE; ++start) {
    for (const int queued : {0, 1, 30, 62}) {
      for (const int size : {1, 2, 11, 15, 32, 63, 100}) {
        Port port;
        romiserial::ArduinoSerial serial(port.serial);
        port.serial.reset_rings(0, start);
        port.busy();  // the UART sends something: every byte below is queued
        std::string before;
        for (int i = 0; i < queued; ++i) before += static_cast<char>('a' + i % 26);
        std::string run;
        for (int i = 0; i < size; ++i) run += static_cast<char>('A' + i % 26);
        const std::vector<uint8_t> first = bytes_of(before);
        const std::vector<uint8_t> second = bytes_of(run);
        if (queued != 0) serial.write_all(first.data(), static_cast<uint8_t>(queued));
        ASSERT_EQ(port.serial.tx_queued(), queued);
        serial.write_all(second.data(), static_cast<uint8_t>(size));
        const std::string where = "start " + std::to_string(start) + ", queued " + std::to_string(queued) +
                                  ", size " + std::to_string(size);
        if (queued + size < SERIAL_TX_BUFFER_SIZE) {  // room for all of it: queued at once, published
          EXPECT_EQ(port.serial.tx_queued(), queued + size) << where;
          EXPECT_NE(port.uart.ucsrb & _BV(UDRIE0), 0u) << where;
        } else {  // the core's write() made room by sending (the byte of busy() first, unrecorded)
          EXPECT_EQ(port.serial.tx_queued(), SERIAL_TX_BUFFER_SIZE - 1) << where;
        }
        EXPECT_EQ(port.sent(), before + run) << where;
      }
    }
  }
}

TEST(ArduinoSerialOnHardwareSerial, RequestsArrivingByteByByteAreAnsweredOnce) {
  Port port;
  romiserial::ArduinoSerial serial(port.serial);
  romiserial::RomiSerial romi(serial, serial, kHandlers, 1);
  for (const char c : request("a", 8)) {  // a sketch's loop: one byte per pass
    port.receive(std::string(1, c));
    romi.handle_input();
  }
  EXPECT_EQ(port.sent(), response('a', "[0]", 8));
}

TEST(ArduinoSerialOnStream, ReadsRunsWithOneAvailableEachAndWritesThroughPrint) {
  CountingStream stream(request("a", 9));
  romiserial::ArduinoSerial serial(static_cast<Stream&>(stream));
  romiserial::RomiSerial romi(serial, serial, kHandlers, 1);
  romi.handle_input();
  EXPECT_EQ(stream.available_calls, 1);
  EXPECT_EQ(stream.output, response('a', "[0]", 9));
}

TEST(CoreSerial, TheCoresPortsAreRecognisedAsStreamsAndNothingElse) {
  Port port;  // a HardwareSerial, but none of the core's ports
  CountingStream stream("");
  EXPECT_EQ(tether::arduino::core_serial(static_cast<Stream*>(&Serial)), &Serial);
  EXPECT_EQ(tether::arduino::core_serial(static_cast<Stream*>(&port.serial)), nullptr);
  EXPECT_EQ(tether::arduino::core_serial(&stream), nullptr);
  EXPECT_EQ(tether::arduino::core_serial(nullptr), nullptr);
}

TEST(ArduinoSerialOnStream, SerialPassedAsAStreamIsReadAndWrittenThroughItsRings) {
  fake_core::wire.clear();
  Serial.reset_rings(0, 0);
  romiserial::ArduinoSerial serial(static_cast<Stream&>(Serial));
  romiserial::RomiSerial romi(serial, serial, kHandlers, 1);
  for (const char c : request("a", 11)) Serial._rx_complete_irq(static_cast<uint8_t>(c));
  fake_core::serial_uart.ucsra = static_cast<uint8_t>(fake_core::serial_uart.ucsra & ~(_BV(UDRE0) | _BV(TXC0)));
  romi.handle_input();
  EXPECT_EQ(Serial.available(), 0);
  EXPECT_EQ(Serial.tx_queued(), response('a', "[0]", 11).size());
  fake_core::transmit(Serial, fake_core::serial_uart);
  EXPECT_EQ(std::string(fake_core::wire.begin(), fake_core::wire.end()), response('a', "[0]", 11));
}

// A user's stream with only per-byte read(): IInputStream's default read_some.
class PerByteStream : public romiserial::IInputStream, public romiserial::IOutputStream {
 public:
  explicit PerByteStream(const std::string& input) : input_(input) {}
  bool available() override {
    ++available_calls;
    return next_ < input_.size();
  }
  bool read(char& c) override {
    if (next_ == input_.size()) return false;
    c = input_[next_++];
    return true;
  }
  bool write(char c) override {
    output += c;
    return true;
  }
  int available_calls = 0;
  std::string output;

 private:
  std::string input_;
  size_t next_ = 0;
};

TEST(DefaultReadSome, AsksAvailableOncePerRunNotPerByte) {
  PerByteStream stream(request("a", 10));
  romiserial::RomiSerial romi(stream, stream, kHandlers, 1);
  romi.handle_input();  // one run of 9 bytes (a batch holds 16)
  EXPECT_EQ(stream.available_calls, 1);
  EXPECT_EQ(stream.output, response('a', "[0]", 10));
  romi.handle_input();  // nothing waiting: one available(), no read()
  EXPECT_EQ(stream.available_calls, 2);
}

// --- TetherElcano: ParseState on the core's ring and on a Stream -----------------------------------------

TEST(ElcanoOnHardwareSerial, AMessageIsCapturedFromTheRingInPlaceAndTheNextWaitsThere) {
  Port port;
  elcano::ParseState ps;
  elcano::SerialData dt;
  ps.dt = &dt;
  ps.input = &port.serial;
  ps.output = &port.serial;
  ps.capture = elcano::MsgType::drive;
  port.serial.reset_rings(55, 0);  // the first message wraps round the ring's end
  port.receive("D{s 50}{a 25}\nD{s -7}{a 3}\n");
  EXPECT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(dt.speed_cmPs, 50);
  EXPECT_EQ(dt.angle_deg, 25);
  EXPECT_EQ(port.serial.available(), 13);  // the second message stays in the ring
  EXPECT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(dt.speed_cmPs, -7);
  EXPECT_EQ(dt.angle_deg, 3);
  EXPECT_EQ(ps.update(), elcano::ParseStateError::unavailable);
  EXPECT_EQ(port.sent(), "");  // captured: nothing forwarded
}

TEST(ElcanoOnHardwareSerial, AMessageArrivingByteByByteIsCapturedOnce) {
  Port port;
  elcano::ParseState ps;
  elcano::SerialData dt;
  ps.dt = &dt;
  ps.input = &port.serial;
  ps.capture = elcano::MsgType::drive;
  int captured = 0;
  for (const char c : std::string("D{s 12}{a 34}\n")) {
    port.receive(std::string(1, c));
    if (ps.update() == elcano::ParseStateError::success) ++captured;
  }
  EXPECT_EQ(captured, 1);
  EXPECT_EQ(dt.speed_cmPs, 12);
}

TEST(ElcanoOnStream, SerialPassedAsAStreamIsReadInPlace) {
  Serial.reset_rings(0, 0);
  elcano::ParseState ps;
  elcano::SerialData dt;
  ps.dt = &dt;
  ps.input = static_cast<Stream*>(&Serial);
  ps.capture = elcano::MsgType::drive;
  EXPECT_EQ(ps.input.ring(), &Serial);
  for (const char c : std::string("D{s 50}{a 25}\nD{s 1}{a 2}\n")) Serial._rx_complete_irq(static_cast<uint8_t>(c));
  EXPECT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(Serial.available(), 12);  // the second message stays in the ring: read in place, not copied
  EXPECT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(dt.speed_cmPs, 1);
}

TEST(ElcanoOnHardwareSerial, ACapturedMessageLeavesEveryFieldItDoesNotCarryNaN) {
  // The reference's SerialData after a capture: the message's fields, NaN for every other one, whatever
  // dt held and whatever came before (a drive with only s and a copies two fields and stores NaN).
  Port port;
  elcano::ParseState ps;
  elcano::SerialData dt;
  ps.dt = &dt;
  ps.input = &port.serial;
  ps.output = &port.serial;
  ps.capture = elcano::MsgType::drive | elcano::MsgType::seg;
  dt.number = dt.bearing_deg = dt.posE_cm = dt.posN_cm = dt.probability = 11;  // set by the sketch
  port.receive("D{s 50}{a 25}\n");
  ASSERT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(dt.kind, elcano::MsgType::drive);
  EXPECT_EQ(dt.speed_cmPs, 50);
  EXPECT_EQ(dt.angle_deg, 25);
  for (const int32_t field : {dt.number, dt.bearing_deg, dt.posE_cm, dt.posN_cm, dt.probability}) {
    EXPECT_EQ(field, elcano::NaN);
  }
  port.receive("X{n 4}{s 160}{b 80}{p 3200,-64000}\n");
  ASSERT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(dt.kind, elcano::MsgType::seg);
  EXPECT_EQ(dt.angle_deg, elcano::NaN);
  EXPECT_EQ(dt.posN_cm, -64000);
  port.receive("D{s 1}{a 2}{b 3}\n");  // an attribute a drive does not carry is read (the reference's)
  ASSERT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(dt.bearing_deg, 3);
  EXPECT_EQ(dt.number, elcano::NaN);
  EXPECT_EQ(dt.posE_cm, elcano::NaN);
  dt.bearing_deg = 12;
  port.receive("D{s 5}{a 6}\n");
  ASSERT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(dt.speed_cmPs, 5);
  EXPECT_EQ(dt.angle_deg, 6);
  for (const int32_t field : {dt.number, dt.bearing_deg, dt.posE_cm, dt.posN_cm, dt.probability}) {
    EXPECT_EQ(field, elcano::NaN);
  }
}

TEST(ElcanoOnStream, AStreamIsReadInRunsWithOneAvailableEach) {
  CountingStream stream("D{s 50}{a 25}\n");
  elcano::ParseState ps;
  elcano::SerialData dt;
  ps.dt = &dt;
  ps.input = &stream;
  ps.capture = elcano::MsgType::drive;
  EXPECT_EQ(ps.update(), elcano::ParseStateError::success);
  EXPECT_EQ(dt.speed_cmPs, 50);
  EXPECT_EQ(stream.available_calls, 1);  // 14 bytes: one run of the 16-byte chunk
  ps.input = nullptr;
  EXPECT_EQ(ps.update(), elcano::ParseStateError::unavailable);
}

}  // namespace
