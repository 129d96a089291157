#include "tether/transports/fault_injecting_stream.hpp"

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/write.hpp>

#include <algorithm>

namespace tether::transports {

std::shared_ptr<FaultInjectingStream> FaultInjectingStream::wrap(std::shared_ptr<ByteStream> inner,
                                                                 const FaultConfig& to_device,
                                                                 const FaultConfig& from_device, std::uint64_t seed) {
  return std::make_shared<FaultInjectingStream>(std::move(inner), to_device, from_device, seed);
}

FaultInjectingStream::FaultInjectingStream(std::shared_ptr<ByteStream> inner, const FaultConfig& to_device,
                                           const FaultConfig& from_device, std::uint64_t seed)
    : ByteStream(inner->get_executor()),
      inner_(std::move(inner)),
      to_device_(to_device, FaultRandom::mix(seed, 1)),
      from_device_(from_device, FaultRandom::mix(seed, 2)),
      scratch_(1024),
      read_delay_(strand()),
      write_delay_(strand()) {}

void FaultInjectingStream::set_faults(const FaultConfig& to_device, const FaultConfig& from_device) {
  std::lock_guard lock(models_mutex_);
  to_device_.set_config(to_device);
  from_device_.set_config(from_device);
}

FaultCounts FaultInjectingStream::to_device_counts() const {
  std::lock_guard lock(models_mutex_);
  return to_device_.counts();
}

FaultCounts FaultInjectingStream::from_device_counts() const {
  std::lock_guard lock(models_mutex_);
  return from_device_.counts();
}

std::string FaultInjectingStream::description() const {
  std::lock_guard lock(models_mutex_);
  return "faults(to device: " + to_device_.config().describe() + "; from device: " +
         from_device_.config().describe() + ") over " + inner_->description();
}

void FaultInjectingStream::do_read(asio::mutable_buffer buffer, IoHandler handler) {
  if (!arrived_.empty()) {
    deliver(buffer, std::move(handler));
    return;
  }
  // Weak, like the base class's read-ahead: a pending inner read must not keep the wrapper alive.
  inner_->async_read_some(
      asio::buffer(scratch_),
      asio::bind_executor(strand(), [this, weak = weak_from_this(), buffer, handler = std::move(handler)](
                                        error_code error, std::size_t size) mutable {
        const auto self = weak.lock();
        if (!self) return;
        if (error) {
          handler(error, 0);
          return;
        }
        std::chrono::nanoseconds delay{0};
        {
          std::lock_guard lock(models_mutex_);
          from_device_.apply(std::span<const std::uint8_t>(scratch_.data(), size), arrived_);
          if (from_device_.config().latency.count() > 0 || from_device_.config().latency_jitter.count() > 0) {
            delay = from_device_.draw_latency();
          }
        }
        if (arrived_.empty()) {  // everything was lost on the line: keep listening
          do_read(buffer, std::move(handler));
          return;
        }
        if (delay.count() == 0) {
          deliver(buffer, std::move(handler));
          return;
        }
        read_delay_.expires_after(delay);
        read_delay_.async_wait([this, self, buffer, handler = std::move(handler)](error_code) mutable {
          deliver(buffer, std::move(handler));
        });
      }));
}

void FaultInjectingStream::deliver(asio::mutable_buffer buffer, IoHandler handler) {
  const std::size_t size = std::min(buffer.size(), arrived_.size());
  std::copy_n(arrived_.begin(), size, static_cast<std::uint8_t*>(buffer.data()));
  arrived_.erase(arrived_.begin(), arrived_.begin() + static_cast<std::ptrdiff_t>(size));
  // Contract: never complete inside do_read; deliver may run inline from it when bytes were waiting.
  asio::post(strand(), [handler = std::move(handler), size]() mutable { handler(error_code(), size); });
}

void FaultInjectingStream::do_write(asio::const_buffer buffer, IoHandler handler) {
  std::chrono::nanoseconds delay{0};
  outgoing_.clear();
  {
    std::lock_guard lock(models_mutex_);
    to_device_.apply(std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(buffer.data()), buffer.size()),
                     outgoing_);
    if (to_device_.config().latency.count() > 0 || to_device_.config().latency_jitter.count() > 0) {
      delay = to_device_.draw_latency();
    }
  }
  auto send = [this, self = shared_from_this(), written = buffer.size(),
               handler = std::move(handler)](error_code) mutable {
    if (outgoing_.empty()) {  // all dropped: the caller still wrote its bytes
      asio::post(strand(), [handler = std::move(handler), written]() mutable { handler(error_code(), written); });
      return;
    }
    asio::async_write(*inner_, asio::buffer(outgoing_),
                      asio::bind_executor(strand(), [handler = std::move(handler), written](
                                                        error_code error, std::size_t) mutable {
                        handler(error, error ? 0 : written);
                      }));
  };
  if (delay.count() == 0) {
    send(error_code());
    return;
  }
  write_delay_.expires_after(delay);
  write_delay_.async_wait(std::move(send));
}

void FaultInjectingStream::do_close(error_code& error) {
  read_delay_.cancel();
  write_delay_.cancel();
  inner_->close(error);
}

}  // namespace tether::transports
