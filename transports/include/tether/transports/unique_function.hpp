/// @file unique_function.hpp
/// A move-only type-erased callable (std::function cannot hold move-only asio handlers such as the one
/// behind `use_future`; std::move_only_function is C++23).
#pragma once

#include <memory>
#include <utility>

namespace tether::transports {

template <typename Signature>
class UniqueFunction;

/// Move-only `R(Args...)` callable. Empty when default-constructed or moved from.
template <typename R, typename... Args>
class UniqueFunction<R(Args...)> {
 public:
  /// Empty function.
  UniqueFunction() = default;
  /// Wraps `function` (any callable invocable as `R(Args...)`, copyable or not).
  template <typename F>
  UniqueFunction(F&& function)  // NOLINT: implicit like std::function
      : impl_(std::make_unique<Impl<std::decay_t<F>>>(std::forward<F>(function))) {}

  /// True when it holds a callable.
  explicit operator bool() const { return impl_ != nullptr; }
  /// Calls the held callable; calling an empty function is undefined.
  R operator()(Args... args) { return impl_->call(std::forward<Args>(args)...); }

 private:
  struct Base {
    virtual ~Base() = default;
    virtual R call(Args... args) = 0;
  };
  template <typename F>
  struct Impl final : Base {
    explicit Impl(F&& f) : function(std::move(f)) {}
    explicit Impl(const F& f) : function(f) {}
    R call(Args... args) override { return function(std::forward<Args>(args)...); }
    F function;
  };
  std::unique_ptr<Base> impl_;
};

}  // namespace tether::transports
