// Elcano codec: the spec's vectors both ways, each error kind, whitespace rules, generation D CRCs,
// overflow, forwarding bytes.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "tether/elcano/decoder.hpp"
#include "tether/elcano/encoder.hpp"
#include "tether/elcano/message.hpp"
#include "tether/testing/random_seed.hpp"

namespace tether::elcano {
namespace {

std::string written(const Message& message, Generation generation) {
  uint8_t out[128];
  const auto size = encode_message(message, generation, out);
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<char*>(out), size.ok() ? size.value() : 0);
}

struct Read {
  std::vector<Message> messages;
  std::vector<Error> errors;
  std::vector<std::string> forwarded;
};

Read read(const std::string& bytes, Generation generation) {
  LinkCounters counters;
  Decoder<> reader(generation, counters);
  Read result;
  for (char c : bytes) {
    const DecodeStatus status = reader.feed(static_cast<uint8_t>(c));
    if (status == DecodeStatus::frame) {
      result.messages.push_back(reader.frame());
      result.forwarded.emplace_back(reinterpret_cast<const char*>(reader.forward().data()), reader.forward().size());
    }
    if (status == DecodeStatus::error) result.errors.push_back(reader.error());
  }
  return result;
}

// The named constructors and operators add no state to a message; the operators are constexpr.
static_assert(sizeof(Message) == 4 + 8 * sizeof(int32_t));
static_assert(Message() == Message() && !(Message() != Message()));

TEST(ElcanoMessage, NamedConstructorsSetTheirTypesFieldsAndLeaveEveryOtherUnset) {
  const Message drive = Message::drive(50, 25);
  EXPECT_EQ(drive.type, Type::drive);
  EXPECT_EQ(drive.speed, 50);
  EXPECT_EQ(drive.angle, 25);
  for (const int32_t field : {drive.number, drive.obstacle, drive.bearing, drive.probability, drive.east,
                              drive.north}) {
    EXPECT_EQ(field, kUnset);
  }
  const Message sensor = Message::sensor(69, -12, 432, 420, 90210);
  EXPECT_EQ(sensor.type, Type::sensor);
  EXPECT_EQ(sensor.speed, 69);
  EXPECT_EQ(sensor.angle, -12);
  EXPECT_EQ(sensor.bearing, 432);
  EXPECT_EQ(sensor.east, 420);
  EXPECT_EQ(sensor.north, 90210);
  for (const int32_t field : {sensor.number, sensor.obstacle, sensor.probability}) EXPECT_EQ(field, kUnset);
  const Message goal = Message::goal(2, 679, 0, 0, 59);
  EXPECT_EQ(goal.type, Type::goal);
  EXPECT_EQ(goal.number, 2);
  EXPECT_EQ(goal.bearing, 679);
  EXPECT_EQ(goal.east, 0);
  EXPECT_EQ(goal.north, 0);
  EXPECT_EQ(goal.probability, 59);
  for (const int32_t field : {goal.speed, goal.angle, goal.obstacle}) EXPECT_EQ(field, kUnset);
  EXPECT_EQ(Message::goal(3, 679, -23456, 123450).probability, kUnset);  // r is optional
  const Message segment = Message::segment(4, 160, 80, 3200, -64000);
  EXPECT_EQ(segment.type, Type::segment);
  EXPECT_EQ(segment.number, 4);
  EXPECT_EQ(segment.speed, 160);
  EXPECT_EQ(segment.bearing, 80);
  EXPECT_EQ(segment.east, 3200);
  EXPECT_EQ(segment.north, -64000);
  for (const int32_t field : {segment.angle, segment.obstacle, segment.probability}) EXPECT_EQ(field, kUnset);
  for (const Message& m : {drive, sensor, goal, segment}) EXPECT_TRUE(has_required_fields(m)) << to_string(m.type);
}

TEST(ElcanoMessage, NamedConstructorsWriteTheSpecsBytesAndEqualWhatIsReadBack) {
  const std::pair<Message, std::string> vectors[] = {
      {Message::drive(50, 25), "D{s 50}{a 25}\n"},
      {Message::sensor(69, -12, 432, 420, 90210), "S{s 69}{a -12}{b 432}{p 420,90210}\n"},
      {Message::goal(3, 679, -23456, 123450), "G{n 3}{b 679}{p -23456,123450}\n"},
      {Message::goal(2, 679, 0, 0, 59), "G{n 2}{b 679}{p 0,0}{r 59}\n"},
      {Message::segment(4, 160, 80, 3200, -64000), "X{n 4}{s 160}{b 80}{p 3200,-64000}\n"},
  };
  for (const auto& [message, bytes] : vectors) {
    EXPECT_EQ(written(message, Generation::b), bytes);
    const Read back = read(bytes, Generation::b);
    ASSERT_EQ(back.messages.size(), 1u) << bytes;
    EXPECT_TRUE(back.messages[0] == message) << bytes;
    EXPECT_FALSE(back.messages[0] != message) << bytes;
  }
}

TEST(ElcanoMessage, EqualityComparesTheTypeAndEveryFieldUnsetIncluded) {
  const Message base = Message::segment(4, 160, 80, 3200, -64000);
  EXPECT_TRUE(base == base);
  EXPECT_FALSE(base != base);
  Message other_type = base;
  other_type.type = Type::goal;
  EXPECT_FALSE(base == other_type);
  EXPECT_TRUE(base != other_type);
  // Each field on its own: changed, and set where the base leaves it unset (kUnset is not 0).
  int32_t Message::*const fields[] = {&Message::number,  &Message::speed,       &Message::angle, &Message::obstacle,
                                      &Message::bearing, &Message::probability, &Message::east,  &Message::north};
  for (int32_t Message::*const field : fields) {
    Message changed = base;
    changed.*field = base.*field == kUnset ? 0 : base.*field + 1;
    EXPECT_FALSE(base == changed) << changed.*field;
    EXPECT_TRUE(base != changed) << changed.*field;
  }
  EXPECT_FALSE(Message::drive(0, 0) == Message());  // a default message is a drive with nothing set
  EXPECT_TRUE(Message::drive(kUnset, kUnset) == Message());
}

TEST(ElcanoWriter, GenerationBVectors) {
  EXPECT_EQ(written(Message::drive(50, 25), Generation::b), "D{s 50}{a 25}\n");
  EXPECT_EQ(written(Message::drive(1500, 60), Generation::b), "D{s 1500}{a 60}\n");
  EXPECT_EQ(written(Message::drive(259, -3), Generation::b), "D{s 259}{a -3}\n");
  EXPECT_EQ(written(Message::sensor(69, -12, 432, 420, 90210), Generation::b),
            "S{s 69}{a -12}{b 432}{p 420,90210}\n");
  EXPECT_EQ(written(Message::sensor(1691, 165, -30, -91, 30), Generation::b), "S{s 1691}{a 165}{b -30}{p -91,30}\n");
  EXPECT_EQ(written(Message::goal(3, 679, -23456, 123450), Generation::b), "G{n 3}{b 679}{p -23456,123450}\n");
  EXPECT_EQ(written(Message::goal(2, 679, 0, 0, 59), Generation::b), "G{n 2}{b 679}{p 0,0}{r 59}\n");
  EXPECT_EQ(written(Message::segment(1, 1599, 270, 14263, 123456), Generation::b),
            "X{n 1}{s 1599}{b 270}{p 14263,123456}\n");
  EXPECT_EQ(written(Message::segment(4, 160, 80, 3200, -64000), Generation::b),
            "X{n 4}{s 160}{b 80}{p 3200,-64000}\n");
}

TEST(ElcanoWriter, GenerationDVectors) {
  EXPECT_EQ(written(Message::drive(50, 25), Generation::d), "D{s50}{a25}74\n");
  EXPECT_EQ(written(Message::drive(1500, 60), Generation::d), "D{s1500}{a60}179\n");
  EXPECT_EQ(written(Message::segment(4, 160, 80, 3200, -64000), Generation::d),
            "X{n4}{s160}{b80}{p3200}{q-64000}243\n");
}

TEST(ElcanoWriter, MissingRequiredFieldIsRejected) {
  Message incomplete;
  incomplete.type = Type::drive;
  incomplete.speed = 5;
  uint8_t out[64];
  EXPECT_EQ(encode_message(incomplete, Generation::b, out).status(), Status::invalid_argument);
}

TEST(ElcanoReader, EveryVectorReadsBackToItsMessage) {
  const std::vector<Message> all = {Message::drive(50, 25), Message::drive(259, -3),
                                    Message::sensor(69, -12, 432, 420, 90210), Message::goal(2, 679, 0, 0, 59),
                                    Message::segment(4, 160, 80, 3200, -64000)};
  for (const Generation generation : {Generation::b, Generation::d}) {
    std::string stream;
    for (const auto& m : all) stream += written(m, generation);
    const Read result = read(stream, generation);
    ASSERT_EQ(result.messages.size(), all.size());
    for (std::size_t i = 0; i < all.size(); ++i) EXPECT_TRUE(result.messages[i] == all[i]) << i;
    EXPECT_TRUE(result.errors.empty());
  }
}

TEST(ElcanoReader, WhitespaceIsIgnoredEverywhereEvenInsideNumbers) {
  static const char kBytes[] = " D\t{ s 1 5\r0 }{a\0 -2 5}\r\n";
  const Read result = read(std::string(kBytes, sizeof kBytes - 1), Generation::b);  // sized: the NUL is data
  ASSERT_EQ(result.messages.size(), 1u);
  EXPECT_EQ(result.messages[0].speed, 150);
  EXPECT_EQ(result.messages[0].angle, -25);
  EXPECT_EQ(result.forwarded[0], "D{s150}{a-25}\n");  // forwarded whitespace-stripped, like the reference
}

TEST(ElcanoReader, GenerationDIsForwardedByteIdentical) {
  const std::string wire = "X{n4}{s160}{b80}{p3200}{q-64000}243\n";
  const Read result = read(wire, Generation::d);
  ASSERT_EQ(result.forwarded.size(), 1u);
  EXPECT_EQ(result.forwarded[0], wire);
}

TEST(ElcanoReader, EachErrorKind) {
  EXPECT_EQ(read("Q{s 1}{a 2}\n", Generation::b).errors, (std::vector<Error>{Error::bad_type}));
  EXPECT_EQ(read("D(s 1}\n", Generation::b).errors, (std::vector<Error>{Error::bad_lcurly}));
  EXPECT_EQ(read("D{z 1}\n", Generation::b).errors, (std::vector<Error>{Error::bad_attrib}));
  EXPECT_EQ(read("D{s 1x}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("D{s --1}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("D{s }\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("D{s 1}\n", Generation::b).errors, (std::vector<Error>{Error::inval_comb}));
  EXPECT_EQ(read("S{s 1}{a 2}{b 3}{p 4}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("D{s50}{a25}75\n", Generation::d).errors, (std::vector<Error>{Error::bad_crc}));
  EXPECT_EQ(read("D{s50}{a25}\n", Generation::d).errors, (std::vector<Error>{Error::bad_crc}));
  EXPECT_EQ(read("D{o5}{s50}{a25}74\n", Generation::b).errors, (std::vector<Error>{Error::bad_attrib}));
  EXPECT_STREQ(describe(Error::inval_comb), "inval_comb");
}

TEST(ElcanoReader, AnAttributeItsTypeDoesNotCarryIsReadAndForwardedUnchanged) {
  // Like the reference reader: lenient on input. The writer writes only the type's own attributes, but a
  // node forwards the bytes it read, so nothing is lost on the ring.
  const Read result = read("D{s 1}{a 2}{b 3}\n", Generation::b);
  ASSERT_EQ(result.messages.size(), 1u);
  EXPECT_EQ(result.messages[0].bearing, 3);
  EXPECT_EQ(result.forwarded[0], "D{s1}{a2}{b3}\n");
  EXPECT_EQ(written(result.messages[0], Generation::b), "D{s 1}{a 2}\n");
}

TEST(ElcanoReader, OverflowingNumbersAreErrorsNotWraps) {
  EXPECT_EQ(read("D{s 99999999999}{a 1}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  const Read edges = read("D{s 2147483646}{a -2147483648}\n", Generation::b);
  ASSERT_EQ(edges.messages.size(), 1u);
  EXPECT_EQ(edges.messages[0].speed, 2147483646);
  EXPECT_EQ(edges.messages[0].angle, INT32_MIN);
  EXPECT_EQ(read("D{s 1}{a -2147483649}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("D{s 2147483650}{a 1}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
}

TEST(ElcanoWriter, NumbersAreWrittenInDecimalAtEveryDigitCountAndReadBack) {
  // The writer formats without division (powers of ten built by multiplying, 16-bit below 65536) and
  // the reader accumulates up to 4 digits in 16 bits, then 32, then with a range check: every digit
  // count, both sides of each switch, and leading zeros.
  const int32_t values[] = {0, 1, 9, 10, 99, 100, 999, 1000, 9999, 10000, 65535, 65536, 99999, 100000,
                            999999, 1000000, 9999999, 10000000, 99999999, 100000000, 999999999, 1000000000,
                            2147483646, -1, -9, -10, -6553, -65535, -65536, -1000000000, INT32_MIN};
  for (const Generation generation : {Generation::b, Generation::d}) {
    for (const int32_t value : values) {
      const Message m = Message::drive(value, -(value / 7));
      const std::string text = written(m, generation);
      const std::string space = generation == Generation::b ? " " : "";
      EXPECT_EQ(text.rfind("D{s" + space + std::to_string(value) + "}{a" + space + std::to_string(-(value / 7)) + "}", 0),
                0u)
          << text;
      const Read back = read(text, generation);
      ASSERT_EQ(back.messages.size(), 1u) << text;
      EXPECT_EQ(back.messages[0].speed, value) << text;
      EXPECT_EQ(back.messages[0].angle, -(value / 7)) << text;
    }
  }
  const Read zeros = read("D{s 0000000000050}{a -00025}\n", Generation::b);
  ASSERT_EQ(zeros.messages.size(), 1u);
  EXPECT_EQ(zeros.messages[0].speed, 50);
  EXPECT_EQ(zeros.messages[0].angle, -25);
}

// docs/elcano.md, "Compatibility with the reference reader": one test per row, with the spec's inputs
// (measured against the reference ElcanoSerial gen B).

// Same as the reference: 2147483647 is its "unset" marker, so the field is unset (not a bad number).
TEST(ElcanoReferenceCompatibility, TheUnsetMarkerLeavesTheFieldUnset) {
  EXPECT_EQ(read("D{s 2147483647}{a 1}\n", Generation::b).errors, (std::vector<Error>{Error::inval_comb}));
  EXPECT_EQ(read("D{s50}{a2147483647}43\n", Generation::d).errors, (std::vector<Error>{Error::inval_comb}));
  // An optional field given as unset: the message is read, the field is unset, the writer leaves it out.
  const Read goal = read("G{n 2}{b 679}{p 0,0}{r 2147483647}\n", Generation::b);
  ASSERT_EQ(goal.messages.size(), 1u);
  EXPECT_EQ(goal.messages[0].probability, kUnset);
  EXPECT_EQ(written(goal.messages[0], Generation::b), "G{n 2}{b 679}{p 0,0}\n");
}

// Stricter: a value without digits is a damaged message (generation B has no checksum), not 0.
TEST(ElcanoReferenceCompatibility, AValueWithoutDigitsIsABadNumberNotZero) {
  EXPECT_EQ(read("D{s}{a 25}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("D{s -}{a 25}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("D{s 1}{a 2}{p ,4}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
}

// Stricter: beyond int32 is an error; the reference wraps 2147483648 to -2147483648.
TEST(ElcanoReferenceCompatibility, BeyondInt32IsABadNumberNotAWrap) {
  EXPECT_EQ(read("D{s 2147483648}{a 1}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_TRUE(read("D{s 2147483648}{a 1}\n", Generation::b).messages.empty());
}

// Kinder: one error per damaged message (the reference: one bad_type per remaining byte of the line), and
// the next message on the same line is read (the reference loses both).
TEST(ElcanoReferenceCompatibility, TwoMessagesOnOneLineLoseOnlyTheFirst) {
  LinkCounters counters;
  Decoder<> reader(Generation::b, counters);
  std::vector<Error> errors;
  std::vector<Message> messages;
  for (char c : std::string("D{s 1}{a 2}D{s 3}{a 4}\n")) {
    const DecodeStatus status = reader.feed(static_cast<uint8_t>(c));
    if (status == DecodeStatus::error) errors.push_back(reader.error());
    if (status == DecodeStatus::frame) messages.push_back(reader.frame());
  }
  EXPECT_EQ(errors, (std::vector<Error>{Error::bad_lcurly}));
  ASSERT_EQ(messages.size(), 1u);
  EXPECT_EQ(messages[0].speed, 3);
  EXPECT_EQ(counters.framing_errors, 1u);
  // After an error, the rest of the line is skipped without an error per byte.
  EXPECT_EQ(read("D{s 1x}{a 2}{b 3}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("Qwerty{s 1}\n", Generation::b).errors, (std::vector<Error>{Error::bad_type}));
}

// Kinder: an empty line is nothing (the reference: bad_type).
TEST(ElcanoReferenceCompatibility, AnEmptyLineIsNotAnError) {
  const Read result = read("\n\r\n \nD{s 1}{a 2}\n", Generation::b);
  EXPECT_TRUE(result.errors.empty());
  EXPECT_EQ(result.messages.size(), 1u);
}

// The same in both readers.
TEST(ElcanoReferenceCompatibility, TheRestIsReadAsTheReferenceReadsIt) {
  Read result = read("D{s 1 2}{a\t3}\r\n", Generation::b);  // spaces inside numbers, tabs, CRLF
  ASSERT_EQ(result.messages.size(), 1u);
  EXPECT_EQ(result.messages[0].speed, 12);
  EXPECT_EQ(result.messages[0].angle, 3);
  result = read("D{s 1}{a 2}{s 7}\n", Generation::b);  // a repeated attribute: the last value wins
  ASSERT_EQ(result.messages.size(), 1u);
  EXPECT_EQ(result.messages[0].speed, 7);
  result = read("D{s -0}{a 2}{r 5}\n", Generation::b);  // -0 is 0; an extra attribute is read
  ASSERT_EQ(result.messages.size(), 1u);
  EXPECT_EQ(result.messages[0].speed, 0);
  EXPECT_EQ(result.messages[0].probability, 5);
  EXPECT_EQ(read("D{z 3}\n", Generation::b).errors, (std::vector<Error>{Error::bad_attrib}));
  EXPECT_EQ(read("Q{s 1}{a 2}\n", Generation::b).errors, (std::vector<Error>{Error::bad_type}));
  EXPECT_EQ(read("d{s 1}{a 2}\n", Generation::b).errors, (std::vector<Error>{Error::bad_type}));
  EXPECT_EQ(read("D{s +1}{a 2}\n", Generation::b).errors, (std::vector<Error>{Error::bad_number}));
  EXPECT_EQ(read("D{s 1}\n", Generation::b).errors, (std::vector<Error>{Error::inval_comb}));
}

TEST(ElcanoReader, FeedReturnsAStatusAndTheDecoderHoldsTheMessageOrError) {
  LinkCounters counters;
  Decoder<> reader(Generation::d, counters);
  std::vector<DecodeStatus> kinds;
  for (char c : std::string("D{s50}{a25}74\nD{s50}{a25}75\n")) {
    const DecodeStatus kind = reader.feed(static_cast<uint8_t>(c));
    if (kind == DecodeStatus::frame) {
      EXPECT_EQ(reader.frame().speed, 50);
      EXPECT_EQ(std::string(reinterpret_cast<const char*>(reader.forward().data()), reader.forward().size()),
                "D{s50}{a25}74\n");
    }
    if (kind == DecodeStatus::error) {
      EXPECT_EQ(reader.error(), Error::bad_crc);
    }
    if (kind != DecodeStatus::more) kinds.push_back(kind);
  }
  EXPECT_EQ(kinds, (std::vector<DecodeStatus>{DecodeStatus::frame, DecodeStatus::error}));
}

TEST(ElcanoReader, SpanFeedingStopsAtEachMessageAndError) {
  // feed(bytes) stops after the byte that completes a message or an error: a read loop sees each one.
  const std::string stream = "D{s 1}{a 2}\nQ{s 1}\nX{n 4}{s 160}{b 80}{p 3200,-64000}\nD{s 1x}\nD{s 3}{a 4}\n";
  const Read expected = read(stream, Generation::b);
  ASSERT_EQ(expected.messages.size(), 3u);
  ASSERT_EQ(expected.errors.size(), 2u);
  for (size_t chunk = 1; chunk <= stream.size(); ++chunk) {
    LinkCounters counters;
    Decoder<> reader(Generation::b, counters);
    std::vector<std::string> forwarded;
    std::vector<Error> errors;
    for (size_t at = 0; at < stream.size(); at += chunk) {
      ByteView rest = ByteView::from_chars(stream.data() + at, std::min(chunk, stream.size() - at));
      while (!rest.empty()) {
        const FeedResult result = reader.feed(rest);
        ASSERT_GE(result.consumed, 1u);
        rest = rest.subview(result.consumed);
        if (result.status == DecodeStatus::frame) {
          forwarded.emplace_back(reinterpret_cast<const char*>(reader.forward().data()), reader.forward().size());
        } else if (result.status == DecodeStatus::error) {
          errors.push_back(reader.error());
        } else {
          ASSERT_TRUE(rest.empty());
        }
      }
    }
    EXPECT_EQ(forwarded, expected.forwarded) << "chunk " << chunk;
    EXPECT_EQ(errors, expected.errors) << "chunk " << chunk;
  }
}

// Everything a decoder reports, in order: each event with its message or error, its forward bytes and
// the counters after it.
struct Trace {
  std::vector<std::string> events;
  bool operator==(const Trace&) const = default;
};

template <size_t Capacity>
void record(Trace& trace, const Decoder<Capacity>& reader, DecodeStatus status, const LinkCounters& counters) {
  if (status == DecodeStatus::more) return;
  std::string event;
  if (status == DecodeStatus::frame) {
    const Message& m = reader.frame();
    event = "frame " + std::string(1, static_cast<char>(m.type));
    for (const int32_t field : {m.number, m.speed, m.angle, m.obstacle, m.bearing, m.probability, m.east, m.north}) {
      event += " " + std::to_string(field);
    }
    event += " [" + std::string(reinterpret_cast<const char*>(reader.forward().data()), reader.forward().size()) + "]";
    event += " fields=" + std::to_string(reader.fields());
  } else {
    event = "error " + std::to_string(static_cast<int>(reader.error()));
  }
  event += " ok=" + std::to_string(counters.frames_ok) + " crc=" + std::to_string(counters.crc_errors) +
           " framing=" + std::to_string(counters.framing_errors) + " oversize=" + std::to_string(counters.oversize_frames) +
           " resyncs=" + std::to_string(counters.resyncs);
  trace.events.push_back(event);
}

template <size_t Capacity>
Trace trace_by_byte(const std::string& bytes, Generation generation) {
  LinkCounters counters;
  Decoder<Capacity> reader(generation, counters);
  Trace trace;
  for (const char c : bytes) record(trace, reader, reader.feed(static_cast<uint8_t>(c)), counters);
  return trace;
}

// The same bytes in chunks of random sizes through feed(bytes) (its loop over runs of attribute bytes).
template <size_t Capacity>
Trace trace_by_span(const std::string& bytes, Generation generation, std::mt19937_64& random) {
  LinkCounters counters;
  Decoder<Capacity> reader(generation, counters);
  Trace trace;
  std::uniform_int_distribution<size_t> chunk_size(1, 40);
  for (size_t at = 0; at < bytes.size();) {
    const size_t chunk = std::min(chunk_size(random), bytes.size() - at);
    ByteView rest = ByteView::from_chars(bytes.data() + at, chunk);
    at += chunk;
    while (!rest.empty()) {
      const FeedResult result = reader.feed(rest);
      EXPECT_GE(result.consumed, 1u);
      if (result.consumed == 0) return trace;
      rest = rest.subview(result.consumed);
      record(trace, reader, result.status, counters);
      if (result.status == DecodeStatus::more) {
        EXPECT_TRUE(rest.empty());
      }
    }
  }
  return trace;
}

// A stream of valid messages of both generations, some with extra spaces, and bytes changed at random:
// digits, signs, separators, headers, line ends, the trailer, long numbers, overlong messages.
std::string random_stream(std::mt19937_64& random) {
  static const std::vector<std::string> pieces = {
      "D{s 50}{a 25}\n", "X{n 4}{s 160}{b 80}{p 3200,-64000}\n", "D{s50}{a25}74\n",
      "X{n4}{s160}{b80}{p3200}{q-64000}243\n", "S{s 1}{a -2}{b 3}{p -4,5}\n", "G{n 1}{b 2}{p 3,4}{r 5}\n",
      "D{ s 5 0 }{a\t25}\r\n", "D{s 2147483647}{a 1}\n", "D{s -2147483648}{a 99999999}\n", "D{s 2147483648}\n",
      "D{s 1234567890}{a -123456789}\n", "{", "}", "-", ",", " ", "\n", "D", "X", "7", "0", "9", "p", "q", "o", "z",
      "\t", "\r", std::string(1, '\0'), "D{s50}{a25}999\n", "D{p 1,2,3}\n", "D{s --1}\n", "G{n1}{b2}{p3}{q4}{o5}88\n",
      std::string(120, '1'), "D{s " + std::string(100, '5') + "}\n", "D{s 1}{a 2}{b 3}\n", "D{s 1}{s 2}{a 3}\n",
      "D{n7}{b8}{a1}{s2}\n"};
  std::uniform_int_distribution<size_t> pick(0, pieces.size() - 1);
  std::uniform_int_distribution<int> count(1, 30);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<int> percent(0, 99);
  std::string stream;
  for (int i = count(random); i > 0; --i) stream += pieces[pick(random)];
  for (char& c : stream) {
    if (percent(random) < 3) c = static_cast<char>(byte(random));
  }
  return stream;
}

// Every field of `m` outside `fields` (Decoder::fields()) is unset.
void expect_unset_outside(const Message& m, uint8_t fields) {
  const std::pair<uint8_t, int32_t> all[] = {
      {field_bits::number, m.number},     {field_bits::speed, m.speed},   {field_bits::angle, m.angle},
      {field_bits::obstacle, m.obstacle}, {field_bits::bearing, m.bearing}, {field_bits::probability, m.probability},
      {field_bits::east, m.east},         {field_bits::north, m.north}};
  for (const auto& [bit, value] : all) {
    if ((fields & bit) == 0) {
      EXPECT_EQ(value, kUnset) << "field bit " << int(bit);
    }
  }
}

TEST(ElcanoReader, FieldsNamesWhatAMessageMaySetAndTheNextMessageSeesNoneOfIt) {
  // A drive carrying only s and a reports those two (field_bits), and the next message's start resets
  // only them: whatever follows, by span or byte by byte, must show none of an earlier message's fields.
  for (const bool by_span : {true, false}) {
    LinkCounters counters;
    Decoder<> reader(Generation::b, counters);
    const auto read = [&](const std::string& text) {
      DecodeStatus last = DecodeStatus::more;
      if (by_span) {
        ByteView rest = ByteView::from_chars(text.data(), text.size());
        while (!rest.empty()) {
          const FeedResult result = reader.feed(rest);
          rest = rest.subview(result.consumed);
          last = result.status;
        }
      } else {
        for (const char c : text) last = reader.feed(static_cast<uint8_t>(c));
      }
      return last;
    };
    const uint8_t drive = field_bits::speed | field_bits::angle;
    ASSERT_EQ(read("D{s 50}{a 25}\n"), DecodeStatus::frame);
    EXPECT_EQ(reader.fields(), drive);
    ASSERT_EQ(read("X{n 4}{s 160}{b 80}{p 3200,-64000}\n"), DecodeStatus::frame);
    EXPECT_EQ(reader.frame(), Message::segment(4, 160, 80, 3200, -64000));
    EXPECT_EQ(reader.fields(), field_bits::all);
    ASSERT_EQ(read("D{s 1}{a 2}\n"), DecodeStatus::frame);
    EXPECT_EQ(reader.frame(), Message::drive(1, 2));
    ASSERT_EQ(read("D{s 1}{a 2}{b 3}\n"), DecodeStatus::frame);  // an extra attribute: any field
    EXPECT_EQ(reader.fields(), field_bits::all);
    EXPECT_EQ(reader.frame().bearing, 3);
    ASSERT_EQ(read("D{s 5}{a 6}\n"), DecodeStatus::frame);
    EXPECT_EQ(reader.frame(), Message::drive(5, 6));
    ASSERT_EQ(read("D{s 5}{s 7}{a 6}\n"), DecodeStatus::frame);  // a repeated one: three attributes
    EXPECT_EQ(reader.fields(), field_bits::all);
    ASSERT_EQ(read("D{s 5}{a 6}\n"), DecodeStatus::frame);
    // A message that fails after a drive: its fields are reset at the next start, all of them.
    ASSERT_EQ(read("S{n 7}{b 3}{r 1}\n"), DecodeStatus::error);
    ASSERT_EQ(read("D{s 8}{a 9}\n"), DecodeStatus::frame);
    EXPECT_EQ(reader.frame(), Message::drive(8, 9));
    EXPECT_EQ(reader.fields(), drive);
    ASSERT_EQ(read("G{n 1}{b 2}{p 3,4}\n"), DecodeStatus::frame);
    EXPECT_EQ(reader.frame(), Message::goal(1, 2, 3, 4));
  }
}

TEST(ElcanoReader, SpanFeedingReportsExactlyWhatByteFeedingDoes) {
  // feed(bytes) runs its own loop over attribute bytes (the AVR's cycles); it must be
  // indistinguishable from feeding the bytes one at a time, whatever the input and the chunking.
  std::mt19937_64 random = testing::seeded_generator(17);
  for (int round = 0; round < 1000; ++round) {
    const std::string stream = random_stream(random);
    for (const Generation generation : {Generation::b, Generation::d}) {
      ASSERT_EQ(trace_by_span<96>(stream, generation, random).events, trace_by_byte<96>(stream, generation).events)
          << "round " << round << " generation " << (generation == Generation::b ? 'B' : 'D');
      ASSERT_EQ(trace_by_span<20>(stream, generation, random).events, trace_by_byte<20>(stream, generation).events)
          << "capacity 20, round " << round << " generation " << (generation == Generation::b ? 'B' : 'D');
    }
  }
}

TEST(ElcanoReader, AMessageReadAfterOthersIsTheMessageAFreshDecoderReads) {
  // A decoder is kept from message to message (a ring node's, for its lifetime) and clears its message
  // at each header: no field of an earlier message may show through (the clearing happens inside
  // feed(bytes)'s run). Each message delivered from a random stream, in random chunks, must equal what a
  // new decoder reads from its forwarded bytes.
  std::mt19937_64 random = testing::seeded_generator(1717);
  std::uniform_int_distribution<size_t> chunk_size(1, 40);
  int compared = 0;
  for (int round = 0; round < 300; ++round) {
    const std::string stream = random_stream(random);
    for (const Generation generation : {Generation::b, Generation::d}) {
      LinkCounters counters;
      Decoder<> reader(generation, counters);
      for (size_t at = 0; at < stream.size();) {
        const size_t chunk = std::min(chunk_size(random), stream.size() - at);
        ByteView rest = ByteView::from_chars(stream.data() + at, chunk);
        at += chunk;
        while (!rest.empty()) {
          const FeedResult result = reader.feed(rest);
          ASSERT_GE(result.consumed, 1u);
          rest = rest.subview(result.consumed);
          if (result.status != DecodeStatus::frame) continue;
          LinkCounters fresh_counters;
          Decoder<> fresh(generation, fresh_counters);
          DecodeStatus last = DecodeStatus::more;
          for (const uint8_t byte : std::vector<uint8_t>(reader.forward().data(),
                                                        reader.forward().data() + reader.forward().size())) {
            last = fresh.feed(byte);
          }
          ASSERT_EQ(last, DecodeStatus::frame) << "round " << round;
          const Message& m = reader.frame();
          const Message& f = fresh.frame();
          EXPECT_EQ(m.type, f.type) << "round " << round;
          EXPECT_EQ(reader.fields(), fresh.fields()) << "round " << round;
          expect_unset_outside(m, reader.fields());
          EXPECT_EQ((std::vector<int32_t>{m.number, m.speed, m.angle, m.obstacle, m.bearing, m.probability, m.east,
                                          m.north}),
                    (std::vector<int32_t>{f.number, f.speed, f.angle, f.obstacle, f.bearing, f.probability, f.east,
                                          f.north}))
              << "round " << round << " generation " << (generation == Generation::b ? 'B' : 'D');
          ++compared;
        }
      }
    }
  }
  EXPECT_GT(compared, 300);  // the streams did deliver messages to compare
}

TEST(ElcanoReader, AfterAnErrorItSkipsToTheNextHeader) {
  const Read result = read("D{s 1x}{a 2}\nG{n 3}{b 679}{p -23456,123450}\n", Generation::b);
  EXPECT_EQ(result.errors, (std::vector<Error>{Error::bad_number}));
  ASSERT_EQ(result.messages.size(), 1u);
  EXPECT_EQ(result.messages[0].type, Type::goal);
}

// A resync means bytes were skipped. An error found at the line end (a required field missing, a bad
// generation D CRC, a `\n` inside an attribute, no room for the `\n`) consumed the whole line: the next
// header starts a message without a resync (`tether monitor` printed "resync skipped bytes" there).
TEST(ElcanoReader, AnErrorAtTheLineEndSkipsNothing) {
  struct Case {
    std::string broken;
    Generation generation;
    Error error;
  };
  const Case cases[] = {
      {"D{s 1}\n", Generation::b, Error::inval_comb},       {"X{n 4}\n", Generation::b, Error::inval_comb},
      {"D{s50}{a25}75\n", Generation::d, Error::bad_crc},    {"D{s50}{a25}\n", Generation::d, Error::bad_crc},
      {"D{s 1\n", Generation::b, Error::bad_number},         {"D{\n", Generation::b, Error::bad_attrib},
      {"D{s 12345}{a 1234}\n", Generation::b, Error::too_long},  // 16 bytes fill Decoder<16>: no room for \n
  };
  for (const Case& c : cases) {
    const std::string next = c.generation == Generation::b ? "D{s 1}{a 2}\n" : "D{s50}{a25}74\n";
    for (const bool by_span : {false, true}) {
      LinkCounters counters;
      Decoder<16> reader(c.generation, counters);
      std::vector<Error> errors;
      int messages = 0;
      const std::string stream = c.broken + next;
      if (by_span) {
        ByteView rest = ByteView::from_chars(stream.data(), stream.size());
        while (!rest.empty()) {
          const FeedResult result = reader.feed(rest);
          rest = rest.subview(result.consumed);
          if (result.status == DecodeStatus::error) errors.push_back(reader.error());
          if (result.status == DecodeStatus::frame) ++messages;
        }
      } else {
        for (const char byte : stream) {
          const DecodeStatus status = reader.feed(static_cast<uint8_t>(byte));
          if (status == DecodeStatus::error) errors.push_back(reader.error());
          if (status == DecodeStatus::frame) ++messages;
        }
      }
      EXPECT_EQ(errors, (std::vector<Error>{c.error})) << c.broken;
      EXPECT_EQ(messages, 1) << c.broken;
      EXPECT_EQ(counters.resyncs, 0u) << c.broken << (by_span ? " fed as a span" : " fed by byte");
    }
  }
  // Bytes really skipped still count: the rest of a line after an error inside it, a header inside a message.
  LinkCounters counters;
  Decoder<> reader(Generation::b, counters);
  for (const char byte : std::string("D{s 1x}{a 2}\nD{s 1}{a 2}\nD{s 1D{s 1}{a 2}\n")) reader.feed(static_cast<uint8_t>(byte));
  EXPECT_EQ(counters.resyncs, 2u);
  EXPECT_EQ(counters.frames_ok, 2u);
}

TEST(ElcanoReader, BoundedAndReportsTooLong) {
  LinkCounters counters;
  Decoder<16> reader(Generation::b, counters);
  Error seen = Error::success;
  for (char c : std::string("S{s 69}{a -12}{b 432}{p 420,90210}\n")) {
    if (reader.feed(static_cast<uint8_t>(c)) == DecodeStatus::error) seen = reader.error();
  }
  EXPECT_EQ(seen, Error::too_long);
  EXPECT_EQ(counters.oversize_frames, 1u);
}

TEST(ElcanoReader, PartialMessageCanBeDroppedAtItsDeadline) {
  LinkCounters counters;
  Decoder<> reader(Generation::b, counters);
  for (char c : std::string("D{s 5")) reader.feed(static_cast<uint8_t>(c));
  EXPECT_TRUE(reader.in_frame());
  reader.reset();  // what a node does when PartialFrameDeadline expires
  EXPECT_FALSE(reader.in_frame());
  int messages = 0;
  for (char c : std::string("0}{a 1}\nD{s 7}{a 8}\n")) {
    if (reader.feed(static_cast<uint8_t>(c)) == DecodeStatus::frame) ++messages;
  }
  EXPECT_EQ(messages, 1);  // the tail of the dropped message never passes as a message
}

// Regression (found by the ring tests, a node reset mid-message): the header that interrupts a half
// message used to be swallowed with it, losing the next whole message too.
TEST(ElcanoReader, HeaderInsideAMessageEndsItAndStartsTheNextOne) {
  for (const Generation generation : {Generation::b, Generation::d}) {
    const std::string next = generation == Generation::b ? "D{s1}{a2}\n" : "D{s50}{a25}74\n";
    const Read result = read("D{s150}{a" + next, generation);
    ASSERT_EQ(result.messages.size(), 1u);
    EXPECT_EQ(result.errors.size(), 1u);
    EXPECT_EQ(result.forwarded[0], next);
  }
  // Inside a number and inside the generation D trailer too.
  EXPECT_EQ(read("X{n 12S{s 1}{a 2}{b 3}{p 4,5}\n", Generation::b).messages.size(), 1u);
  EXPECT_EQ(read("D{s50}{a25}7D{s50}{a25}74\n", Generation::d).messages.size(), 1u);
}

TEST(ElcanoTypes, NamesAndHeaderLettersRoundTrip) {
  for (const Type type : {Type::drive, Type::sensor, Type::goal, Type::segment}) {
    const char* name = to_string(type);
    Type parsed = Type::drive;
    EXPECT_TRUE(type_from_name(ByteView::from_chars(name, std::string(name).size()), parsed)) << name;
    EXPECT_EQ(parsed, type);
    const char letter = static_cast<char>(type);
    EXPECT_TRUE(type_from_name(ByteView::from_chars(&letter, 1), parsed));
    EXPECT_EQ(parsed, type);
  }
  Type unchanged = Type::goal;
  EXPECT_FALSE(type_from_name(ByteView::from_literal("driv"), unchanged));
  EXPECT_FALSE(type_from_name(ByteView::from_literal("drives"), unchanged));
  EXPECT_FALSE(type_from_name(ByteView::from_literal("d"), unchanged));
  EXPECT_FALSE(type_from_name(ByteView(), unchanged));
  EXPECT_EQ(unchanged, Type::goal);
}

}  // namespace
}  // namespace tether::elcano
