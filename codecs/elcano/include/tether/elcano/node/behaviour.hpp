/// @file behaviour.hpp
/// What an `elcano-node` does with the messages it captures: the answers and the servo mapping, pure and
/// portable so the host tests compute the expected values with the very same code.
///
/// Units: speeds cm/s, angles and bearings degrees (bearings compass-style, steering positive = right).
///   - goal -> segment: `X{n}{s kCruiseSpeed}{b}{p}`, n, b and p copied from the goal.
///   - segment -> drive: `D{s = segment s}{a = steering(segment b, heading)}`; the segment is remembered.
///   - sensor -> drive: the sensor's `b` becomes the heading; `D{s = remembered segment s}{a = steering(
///     remembered segment b, heading)}`, or `D{s 0}{a 0}` (stop, wheels straight) before any segment.
///   - steering(target, heading) = clamp(wrap(target - heading), -kMaxSteering, +kMaxSteering), wrap into
///     [-180, 180); the heading is 0 until a sensor arrives.
///   - drive -> servos: throttle (D9) `1500 + clamp(s, -1000, 1000) / 2` us, steering (D10)
///     `1500 + clamp(a, -45, 45) * 100 / 9` us (integer division, towards zero): 1000..2000 us both.
///   - drive -> sensor report: `S{s}{a}{b 0}{p 0,0}` with the drive's s and a.
#pragma once

#include <stdint.h>

#include "tether/elcano/message.hpp"
#include "tether/elcano/node/config.hpp"

namespace tether {
namespace elcano {
namespace node {

/// Speed of the segment a goal is answered with (cm/s).
constexpr int32_t kCruiseSpeed = 150;
/// Largest steering angle (degrees), either side.
constexpr int32_t kMaxSteering = 45;
/// Largest speed the throttle mapping distinguishes (cm/s), either way.
constexpr int32_t kMaxServoSpeed = 1000;
/// Neutral servo pulse (us): stopped, wheels straight. Driven from boot when servos are enabled.
constexpr uint16_t kNeutralPulseUs = 1500;

/// `degrees` folded into [-180, 180).
inline int32_t wrap_degrees(int32_t degrees) {
  int32_t folded = degrees % 360;  // (-360, 360): no overflow below
  if (folded >= 180) folded -= 360;
  if (folded < -180) folded += 360;
  return folded;
}

/// Steering angle that turns `heading` towards `target` (see the file comment).
inline int32_t steering_for(int32_t target, int32_t heading) {
  const int32_t error = wrap_degrees(wrap_degrees(target) - wrap_degrees(heading));
  return error > kMaxSteering ? kMaxSteering : (error < -kMaxSteering ? -kMaxSteering : error);
}

/// Throttle servo pulse (us) for `speed` cm/s.
inline uint16_t throttle_pulse_us(int32_t speed) {
  const int32_t clamped = speed > kMaxServoSpeed ? kMaxServoSpeed : (speed < -kMaxServoSpeed ? -kMaxServoSpeed : speed);
  return static_cast<uint16_t>(static_cast<int32_t>(kNeutralPulseUs) + clamped / 2);
}

/// Steering servo pulse (us) for `angle` degrees.
inline uint16_t steering_pulse_us(int32_t angle) {
  const int32_t clamped = angle > kMaxSteering ? kMaxSteering : (angle < -kMaxSteering ? -kMaxSteering : angle);
  return static_cast<uint16_t>(static_cast<int32_t>(kNeutralPulseUs) + clamped * 100 / 9);
}

/// What a node does about one captured message.
struct Reaction {
  bool answer = false;     ///< Originate `message`.
  Message message;         ///< The answer.
  bool drive = false;      ///< Set the servos to `throttle_us` / `steering_us`.
  uint16_t throttle_us = kNeutralPulseUs;  ///< D9 pulse.
  uint16_t steering_us = kNeutralPulseUs;  ///< D10 pulse.
};

/// The behaviours of one node (behaviour bits of NodeConfig) and the little they remember.
class Behaviour {
 public:
  /// Node with the k* behaviour `bits`.
  explicit Behaviour(uint8_t bits) : bits_(bits) {}

  /// Reaction to a captured `message`.
  Reaction on_captured(const Message& message) {
    // The answers are written field by field into the Reaction's message (all unset), not assigned from
    // Message::segment/sensor/drive: avr-gcc builds a whole temporary and copies it, which cost the
    // elcano-node image 162 bytes of code and 66 of initialised RAM.
    Reaction reaction;
    switch (message.type) {
      case Type::goal:
        if ((bits_ & kAnswerGoalWithSegment) != 0) {
          reaction.answer = true;
          reaction.message.type = Type::segment;
          reaction.message.number = message.number;
          reaction.message.speed = kCruiseSpeed;
          reaction.message.bearing = message.bearing;
          reaction.message.east = message.east;
          reaction.message.north = message.north;
        }
        break;
      case Type::segment:
        has_segment_ = true;
        segment_speed_ = message.speed;
        segment_bearing_ = message.bearing;
        if ((bits_ & kAnswerSegmentWithDrive) != 0) answer_drive(reaction);
        break;
      case Type::sensor:
        heading_ = message.bearing;
        if ((bits_ & kAnswerSensorWithDrive) != 0) answer_drive(reaction);
        break;
      case Type::drive:
        if ((bits_ & kDriveServos) != 0) {
          reaction.drive = true;
          reaction.throttle_us = throttle_pulse_us(message.speed);
          reaction.steering_us = steering_pulse_us(message.angle);
        }
        if ((bits_ & kReportDriveAsSensor) != 0) {
          reaction.answer = true;
          reaction.message.type = Type::sensor;
          reaction.message.speed = message.speed;
          reaction.message.angle = message.angle;
          reaction.message.bearing = 0;
          reaction.message.east = 0;
          reaction.message.north = 0;
        }
        break;
    }
    return reaction;
  }

 private:
  void answer_drive(Reaction& reaction) const {
    reaction.answer = true;
    reaction.message.type = Type::drive;
    reaction.message.speed = has_segment_ ? segment_speed_ : 0;
    reaction.message.angle = has_segment_ ? steering_for(segment_bearing_, heading_) : 0;
  }

  uint8_t bits_;
  bool has_segment_ = false;
  int32_t segment_speed_ = 0;
  int32_t segment_bearing_ = 0;
  int32_t heading_ = 0;
};

}  // namespace node
}  // namespace elcano
}  // namespace tether
