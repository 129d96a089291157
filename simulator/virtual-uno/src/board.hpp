// Internal: the state behind VirtualUno (one simulated board) and VirtualUnoGroup (the lockstep runner).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "pty.hpp"
#include "simavr_glue.hpp"
#include "tether/transports/fault_model.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::transports {

struct VirtualUno::Impl {
  explicit Impl(VirtualUnoOptions board_options);
  ~Impl();

  // --- constant after construction -----------------------------------------------------------------
  VirtualUnoOptions options;
  detail::SymbolTable symbols;  // the image's, filled by load_avr
  avr_t* avr = nullptr;
  avr_uart_t* uart = nullptr;
  avr_irq_t* uart_irq = nullptr;    // UART_IRQ_* of UART0
  avr_irq_t* adc_irq = nullptr;     // ADC_IRQ_*
  avr_irq_t* port_irq[3] = {};      // IOPORT_IRQ_* of ports B, C, D
  struct PinWatch {
    Impl* board;
    int port;  // 0 = B, 1 = C, 2 = D
    int bit;
  };
  PinWatch pin_watch[3][8];
  // A watched I/O register: the simavr handlers it had, chained behind ours, and what we recorded.
  struct IoWatch {
    Impl* board;
    std::uint16_t address;
    avr_io_read_t read;  // the register's own handlers (null: plain memory)
    void* read_param;
    avr_io_write_t write;
    void* write_param;
    std::size_t limit;
    std::vector<IoAccess> accesses;
    std::uint64_t dropped = 0;
    void record(std::uint8_t value, bool is_write);
  };
  std::map<std::uint16_t, std::unique_ptr<IoWatch>> io_watches;  // simulation thread only
  static std::uint8_t on_watched_read(avr_t* avr, avr_io_addr_t address, void* param);
  static void on_watched_write(avr_t* avr, avr_io_addr_t address, std::uint8_t value, void* param);

  // --- group membership (changed only while nobody advances the board) ------------------------------
  std::atomic<VirtualUnoGroup::Impl*> group{nullptr};
  std::unique_ptr<VirtualUnoGroup::Impl> own_group;  // the private group of a standalone board
  Impl* tx_peer = nullptr;    // where this board's TX goes (nullptr: the host)
  Impl* rx_source = nullptr;  // the board whose TX drives this RX

  bool on_sim_thread() const;

  // --- commands: run on the simulation thread at a quantum boundary, or inline when nobody advances ---
  template <class F>
  auto execute(F&& function) const -> decltype(function());
  std::mutex exec_mutex;   // guards `active` and direct execution
  bool active = false;     // a thread (group thread or run_for) advances this board
  std::mutex command_mutex;
  std::vector<std::function<void()>> commands;
  std::atomic<bool> commands_pending{false};
  void run_commands();
  void activate();
  void deactivate(bool close_pty);

  // --- the simulation (simulation thread only) ---------------------------------------------------------
  struct RxItem {
    std::uint8_t byte;
    std::uint64_t ready_at;
  };
  struct TxItem {
    std::uint8_t byte;
    std::uint64_t deliver_at;
  };
  struct WireItem {
    std::uint8_t byte;
    std::uint64_t start;  // when it started on the wire (plus the sender's fault latency)
  };
  struct ScheduledReset {
    ResetKind kind;
    std::uint64_t off_cycles;
  };
  struct EdgeRecord {
    std::uint64_t edges = 0;
    bool level = false;
    std::uint64_t last_edge = 0;
    std::uint64_t last_rise = 0;
    bool rose = false;
    std::uint64_t high = 0;
    std::uint64_t period = 0;
  };

  std::deque<RxItem> rx_queue;
  std::uint64_t rx_wire_free = 0;
  std::uint64_t rx_last_ready = 0;
  bool xoff = false;
  std::deque<TxItem> tx_queue;
  std::uint64_t tx_wire_free = 0;
  std::uint64_t tx_last_deliver = 0;
  std::vector<WireItem> outbound;  // TX towards tx_peer, moved at the quantum boundary
  std::multimap<std::uint64_t, ScheduledReset> scheduled_resets;
  bool powered_off = false;
  std::uint64_t power_on_at = 0;
  bool resetting = false;  // inside a reset this class started
  bool wake = false;       // something changed: re-plan the next event
  FaultModel to_mcu_faults;
  FaultModel from_mcu_faults;
  FaultRandom power_up_random;
  EdgeRecord edges[3][8];
  std::uint8_t driven_mask[3] = {};   // pins driven from outside (set_input_level)
  std::uint8_t driven_value[3] = {};
  VirtualUnoStats stats;               // fault counts are filled in by stats()
  std::uint64_t slept_cycles = 0;      // cycles SLEEP skipped (no_sleep), to leave out of stats.awake_cycles
  std::unique_ptr<detail::Pty> pty;
  bool pty_poll_due = false;
  std::vector<std::uint8_t> scratch;

  std::uint64_t now() const { return avr->cycle; }
  std::uint64_t cycles_per_byte() const;
  bool rx_enabled() const;
  bool tx_enabled() const;
  void begin_quantum(bool poll_pty);
  void run_until(std::uint64_t target);
  void process_events();
  std::uint64_t next_event(std::uint64_t limit) const;
  void accept_rx(std::uint8_t byte, std::uint64_t earliest);
  void accept_host_bytes(const std::uint8_t* data, std::size_t size);
  void deliver_to_host(const std::uint8_t* data, std::size_t size);
  void move_outbound(std::uint64_t link_latency);
  void do_reset(ResetKind kind, std::uint64_t off_cycles);
  void power_on();
  void publish() { published_cycles.store(avr->cycle, std::memory_order_relaxed); }

  // simavr callbacks
  static void on_uart_output(avr_irq_t* irq, std::uint32_t value, void* param);
  static void on_uart_xon(avr_irq_t* irq, std::uint32_t value, void* param);
  static void on_uart_xoff(avr_irq_t* irq, std::uint32_t value, void* param);
  static void on_pin(avr_irq_t* irq, std::uint32_t value, void* param);
  void on_core_reset();

  // --- host side (any thread) --------------------------------------------------------------------------
  std::atomic<std::uint64_t> published_cycles{0};
  std::mutex host_in_mutex;
  std::vector<std::uint8_t> host_in;
  std::atomic<bool> host_in_pending{false};
  mutable std::mutex read_mutex;
  std::condition_variable read_ready;
  std::deque<std::uint8_t> read_buffer;
  std::uint64_t read_discarded = 0;  // guarded by read_mutex
  std::recursive_mutex handler_mutex;
  std::shared_ptr<OutputHandler> handler;
};

struct VirtualUnoGroup::Impl {
  Impl(Pacing group_pacing, SimDuration group_quantum) : pacing(group_pacing), quantum(group_quantum) {}
  ~Impl();

  Pacing pacing;
  SimDuration quantum;
  std::vector<VirtualUno::Impl*> members;
  std::uint64_t clock = 0;  // simulated cycle every member has reached
  std::thread thread;
  std::atomic<bool> stop_requested{false};
  std::atomic<std::thread::id> sim_thread{};
  std::atomic<int> wake_fd{-1};
  std::mutex control;  // membership, start, stop, run_for

  void add(VirtualUno::Impl* board);
  void remove(VirtualUno::Impl* board);
  void start();
  void stop();
  void run_for(SimDuration duration);
  bool running() const { return is_running.load(); }
  std::atomic<bool> is_running{false};  // a thread runs the group (readable from any thread)
  void wake() const;
  std::uint64_t quantum_cycles() const;
  void advance(std::uint64_t end, bool threaded);
  void wait_for(std::chrono::nanoseconds duration);
};

template <class F>
auto VirtualUno::Impl::execute(F&& function) const -> decltype(function()) {
  auto* self = const_cast<Impl*>(this);
  if (on_sim_thread()) return function();
  std::unique_lock lock(self->exec_mutex);
  if (!self->active) return function();
  using Result = decltype(function());
  std::packaged_task<Result()> task(std::forward<F>(function));
  auto future = task.get_future();
  {
    std::lock_guard commands_lock(self->command_mutex);
    self->commands.emplace_back([&task] { task(); });
    self->commands_pending.store(true, std::memory_order_release);
  }
  if (auto* owner = group.load()) owner->wake();
  lock.unlock();
  return future.get();
}

}  // namespace tether::transports
