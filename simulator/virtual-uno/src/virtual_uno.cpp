#include "tether/transports/virtual_uno.hpp"

#include <poll.h>
#include <pthread.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

#include "board.hpp"

namespace tether::transports {

namespace {

using Board = VirtualUno::Impl;
using GroupImpl = VirtualUnoGroup::Impl;
namespace reg = atmega328p;

constexpr std::uint64_t kNanosPerSecond = 1'000'000'000;

std::uint64_t cycles_for(SimDuration duration, std::uint32_t frequency) {
  if (duration.count() <= 0) return 0;
  const auto product = static_cast<unsigned __int128>(duration.count()) * frequency;
  return static_cast<std::uint64_t>(product / kNanosPerSecond);
}

SimDuration duration_for(std::uint64_t cycles, std::uint32_t frequency) {
  const auto product = static_cast<unsigned __int128>(cycles) * kNanosPerSecond;
  return SimDuration(static_cast<SimDuration::rep>(product / frequency));
}

// The board whose simavr calls are on this thread's stack (for the core reset hook, which has no parameter).
thread_local Board* t_board = nullptr;

struct BoardScope {
  explicit BoardScope(Board* board) : previous(t_board) { t_board = board; }
  ~BoardScope() { t_board = previous; }
  Board* previous;
};

// The MCU's own reset function (the same for every atmega328p), called before ours.
std::atomic<void (*)(avr_t*)> g_core_reset{nullptr};

void core_reset_hook(avr_t* avr) {
  if (auto* original = g_core_reset.load()) original(avr);
  if (t_board != nullptr && t_board->avr == avr) t_board->on_core_reset();
}

// Pacing is ours: simavr must never sleep. The cycles a SLEEP skips are counted, so that
// `VirtualUnoStats::awake_cycles` leaves them out.
void no_sleep(avr_t* avr, avr_cycle_count_t how_long) {
  if (t_board != nullptr && t_board->avr == avr) t_board->slept_cycles += how_long;
}

// A cycle timer that does nothing: it only bounds how far a sleeping CPU jumps ahead.
avr_cycle_count_t stop_timer(avr_t* /*avr*/, avr_cycle_count_t /*when*/, void* /*param*/) { return 0; }

// Arduino pin -> (port index 0=B 1=C 2=D, bit).
std::pair<int, int> locate(int arduino_pin) {
  if (arduino_pin < 0 || arduino_pin >= uno_pins::kCount) {
    throw std::out_of_range("virtual Uno: no Arduino pin " + std::to_string(arduino_pin) + " (0..19)");
  }
  if (arduino_pin < 8) return {2, arduino_pin};
  if (arduino_pin < 14) return {0, arduino_pin - 8};
  return {1, arduino_pin - 14};
}

constexpr std::uint16_t kPortAddress[3] = {reg::PORTB, reg::PORTC, reg::PORTD};
constexpr std::uint16_t kDdrAddress[3] = {reg::DDRB, reg::DDRC, reg::DDRD};
constexpr std::uint16_t kPinAddress[3] = {reg::PINB, reg::PINC, reg::PIND};

int port_index(char name) {
  switch (name) {
    case 'B': case 'b': return 0;
    case 'C': case 'c': return 1;
    case 'D': case 'd': return 2;
    default: throw std::out_of_range(std::string("virtual Uno: no port ") + name + " (B, C or D)");
  }
}

}  // namespace

// ===================================================================================================
// Board
// ===================================================================================================

Board::Impl(VirtualUnoOptions board_options)
    : options(std::move(board_options)),
      to_mcu_faults(options.to_mcu_faults, FaultRandom::mix(options.seed, 1)),
      from_mcu_faults(options.from_mcu_faults, FaultRandom::mix(options.seed, 2)),
      power_up_random(FaultRandom::mix(options.seed, 3)) {
  if (options.frequency_hz == 0) throw std::invalid_argument("virtual Uno: frequency_hz must not be 0");
  if (options.quantum.count() <= 0) throw std::invalid_argument("virtual Uno: quantum must be positive");
  if (options.name.empty()) {
    options.name = options.firmware.empty() ? options.bootloader.filename().string() : options.firmware.filename().string();
  }
  if (options.firmware.empty() && options.bootloader.empty()) {
    throw std::invalid_argument("virtual Uno: no firmware image (only a board with a bootloader may start blank)");
  }
  avr = detail::load_avr(options.firmware, options.frequency_hz, &symbols);
  try {
    if (!options.bootloader.empty()) detail::load_bootloader(avr, options.bootloader);
    for (avr_io_t* io = avr->io_port; io != nullptr; io = io->next) {
      if (io->kind != nullptr && std::strcmp(io->kind, "uart") == 0 && reinterpret_cast<avr_uart_t*>(io)->name == '0') {
        uart = reinterpret_cast<avr_uart_t*>(io);
      }
    }
    uart_irq = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), 0);
    adc_irq = avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, 0);
    for (int port = 0; port < 3; ++port) {
      port_irq[port] = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(static_cast<std::uint32_t>('B' + port)), 0);
    }
    if (uart == nullptr || uart_irq == nullptr || adc_irq == nullptr || port_irq[0] == nullptr ||
        port_irq[1] == nullptr || port_irq[2] == nullptr) {
      throw std::system_error(make_error_code(VirtualUnoError::simulator_failed),
                              "virtual Uno: libsimavr's atmega328p lacks UART0, the ADC or a port");
    }
    // No console lines on stdout, no usleep() while the firmware polls UCSR0A.
    std::uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(uart_irq + UART_IRQ_OUTPUT, &Board::on_uart_output, this);
    avr_irq_register_notify(uart_irq + UART_IRQ_OUT_XON, &Board::on_uart_xon, this);
    avr_irq_register_notify(uart_irq + UART_IRQ_OUT_XOFF, &Board::on_uart_xoff, this);
    for (int port = 0; port < 3; ++port) {
      for (int bit = 0; bit < 8; ++bit) {
        pin_watch[port][bit] = PinWatch{this, port, bit};
        avr_irq_register_notify(port_irq[port] + bit, &Board::on_pin, &pin_watch[port][bit]);
      }
    }
    avr->sleep = no_sleep;
    if (avr->reset != core_reset_hook) {
      g_core_reset.store(avr->reset);
      avr->reset = core_reset_hook;
    }
    stats.boots = 1;  // the power-on avr_init() did
  } catch (...) {
    detail::destroy_avr(avr);
    throw;
  }
}

Board::~Impl() {
  pty.reset();
  detail::destroy_avr(avr);
}

bool Board::on_sim_thread() const {
  const GroupImpl* owner = group.load();
  return owner != nullptr && owner->sim_thread.load() == std::this_thread::get_id();
}

void Board::run_commands() {
  std::vector<std::function<void()>> batch;
  {
    std::lock_guard lock(command_mutex);
    batch.swap(commands);
  }
  BoardScope scope(this);
  for (auto& command : batch) command();
}

void Board::activate() {
  std::lock_guard lock(exec_mutex);
  active = true;
}

void Board::deactivate(bool close_pty) {
  std::lock_guard lock(exec_mutex);
  run_commands();  // whatever was queued after the last boundary
  commands_pending.store(false);
  active = false;
  if (close_pty) pty.reset();
  publish();
}

std::uint64_t Board::cycles_per_byte() const { return uart->cycles_per_byte > 0 ? uart->cycles_per_byte : 1; }
bool Board::rx_enabled() const { return avr_regbit_get(avr, uart->rxen) != 0; }
bool Board::tx_enabled() const { return avr_regbit_get(avr, uart->txen) != 0; }

void Board::begin_quantum(bool poll_pty) {
  if (commands_pending.exchange(false, std::memory_order_acquire)) run_commands();
  if (host_in_pending.exchange(false, std::memory_order_acquire)) {
    std::vector<std::uint8_t> input;
    {
      std::lock_guard lock(host_in_mutex);
      input.swap(host_in);
    }
    accept_host_bytes(input.data(), input.size());
  }
  if (pty && (poll_pty || pty_poll_due)) {
    pty_poll_due = false;
    // A client opened the port: the Uno's DTR edge resets the MCU before the client's first byte arrives.
    if (options.reset_on_open && pty->client_opened()) {
      ++stats.port_open_resets;
      do_reset(ResetKind::external, 0);
    }
    std::deque<std::uint8_t> input;
    pty->read_input(input, 64 * 1024);
    for (const std::uint8_t byte : input) accept_rx(byte, now());
    pty->flush();
  }
}

void Board::accept_host_bytes(const std::uint8_t* data, std::size_t size) {
  for (std::size_t i = 0; i < size; ++i) accept_rx(data[i], now());
}

// A byte starts arriving on this board's RX line at `earliest` (before to_mcu faults).
void Board::accept_rx(std::uint8_t byte, std::uint64_t earliest) {
  scratch.clear();
  to_mcu_faults.apply_byte(byte, scratch);
  if (scratch.empty()) return;
  std::uint64_t delay = 0;
  const auto& config = to_mcu_faults.config();
  if (config.latency.count() > 0 || config.latency_jitter.count() > 0) {
    delay = cycles_for(to_mcu_faults.draw_latency(), options.frequency_hz);
  }
  for (const std::uint8_t out : scratch) {
    rx_last_ready = std::max(rx_last_ready, earliest + delay);
    rx_queue.push_back(RxItem{out, rx_last_ready});
  }
}

void Board::on_uart_output(avr_irq_t* /*irq*/, std::uint32_t value, void* param) {
  auto* self = static_cast<Board*>(param);
  ++self->stats.tx_bytes;
  const std::uint64_t t = self->now();
  const std::uint64_t byte_time = self->cycles_per_byte();
  const std::uint64_t start = std::max(t, self->tx_wire_free);
  self->tx_wire_free = start + byte_time;
  thread_local std::vector<std::uint8_t> out;
  out.clear();
  self->from_mcu_faults.apply_byte(static_cast<std::uint8_t>(value), out);
  if (out.empty()) return;
  std::uint64_t delay = 0;
  const auto& config = self->from_mcu_faults.config();
  if (config.latency.count() > 0 || config.latency_jitter.count() > 0) {
    delay = cycles_for(self->from_mcu_faults.draw_latency(), self->options.frequency_hz);
  }
  for (const std::uint8_t byte : out) {
    if (self->tx_peer != nullptr) {
      self->outbound.push_back(WireItem{byte, start + delay});
    } else {
      self->tx_last_deliver = std::max(self->tx_last_deliver, start + byte_time + delay);
      self->tx_queue.push_back(TxItem{byte, self->tx_last_deliver});
      self->wake = true;
    }
  }
}

void Board::on_uart_xon(avr_irq_t* /*irq*/, std::uint32_t /*value*/, void* param) {
  auto* self = static_cast<Board*>(param);
  if (self->xoff) {
    self->xoff = false;
    if (!self->rx_queue.empty()) self->wake = true;
  }
}

void Board::on_uart_xoff(avr_irq_t* /*irq*/, std::uint32_t value, void* param) {
  auto* self = static_cast<Board*>(param);
  self->xoff = value != 0;
  if (!self->xoff && !self->rx_queue.empty()) self->wake = true;
}

void Board::on_pin(avr_irq_t* /*irq*/, std::uint32_t value, void* param) {
  const auto* watch = static_cast<PinWatch*>(param);
  Board* self = watch->board;
  const bool level = (value & 0xFFu) != 0;
  EdgeRecord& record = self->edges[watch->port][watch->bit];
  if (record.level == level) return;
  const std::uint64_t t = self->now();
  if (level) {
    if (record.rose) record.period = t - record.last_rise;
    record.last_rise = t;
    record.rose = true;
  } else if (record.rose) {
    record.high = t - record.last_rise;
  }
  record.level = level;
  record.last_edge = t;
  ++record.edges;
}

void Board::on_core_reset() {
  ++stats.boots;
  if (!resetting) ++stats.firmware_watchdog_resets;  // the only reset simavr starts by itself
  xoff = false;
  wake = true;
}

void Board::do_reset(ResetKind kind, std::uint64_t off_cycles) {
  BoardScope scope(this);
  switch (kind) {
    case ResetKind::watchdog:
    case ResetKind::external: {
      // MCUSR keeps earlier flags across resets on the real part; simavr's avr_reset() zeroes all I/O.
      const std::uint8_t saved = avr->data[reg::MCUSR];
      resetting = true;
      avr_reset(avr);
      resetting = false;
      avr->data[reg::MCUSR] = static_cast<std::uint8_t>(saved | (kind == ResetKind::watchdog ? reg::WDRF : reg::EXTRF));
      ++(kind == ResetKind::watchdog ? stats.injected_watchdog_resets : stats.injected_external_resets);
      break;
    }
    case ResetKind::power_cycle:
      ++stats.power_cycles;
      if (off_cycles > 0) {
        powered_off = true;
        power_on_at = now() + off_cycles;
      } else {
        power_on();
      }
      break;
  }
  xoff = false;
  wake = true;
}

void Board::power_on() {
  BoardScope scope(this);
  // SRAM and the register file power up with unpredictable contents; seeded, so runs replay.
  for (std::uint16_t address = 0; address < 32; ++address) {
    avr->data[address] = static_cast<std::uint8_t>(power_up_random.next());
  }
  for (std::uint32_t address = reg::kSramStart; address <= avr->ramend; ++address) {
    avr->data[address] = static_cast<std::uint8_t>(power_up_random.next());
  }
  resetting = true;
  avr_reset(avr);
  resetting = false;
  avr->data[reg::MCUSR] = reg::PORF;
  powered_off = false;
}

std::uint64_t Board::next_event(std::uint64_t limit) const {
  std::uint64_t next = limit;
  if (!scheduled_resets.empty()) next = std::min(next, scheduled_resets.begin()->first);
  if (powered_off) next = std::min(next, power_on_at);
  if (!tx_queue.empty()) next = std::min(next, tx_queue.front().deliver_at);
  if (!rx_queue.empty()) {
    const bool waiting_for_xon = !powered_off && rx_enabled() && xoff;
    if (!waiting_for_xon) next = std::min(next, std::max(rx_queue.front().ready_at, rx_wire_free));
  }
  return next;
}

void Board::process_events() {
  const std::uint64_t t = now();
  while (!scheduled_resets.empty() && scheduled_resets.begin()->first <= t) {
    const ScheduledReset request = scheduled_resets.begin()->second;
    scheduled_resets.erase(scheduled_resets.begin());
    do_reset(request.kind, request.off_cycles);
  }
  if (powered_off && t >= power_on_at) power_on();

  if (!tx_queue.empty() && tx_queue.front().deliver_at <= t) {
    std::vector<std::uint8_t> batch;
    while (!tx_queue.empty() && tx_queue.front().deliver_at <= t) {
      batch.push_back(tx_queue.front().byte);
      tx_queue.pop_front();
    }
    deliver_to_host(batch.data(), batch.size());
  }

  while (!rx_queue.empty()) {
    const RxItem item = rx_queue.front();
    const std::uint64_t at = std::max(item.ready_at, rx_wire_free);
    if (at > t) break;
    if (powered_off || !rx_enabled()) {  // nobody listens: the byte is lost, as on the real board
      rx_queue.pop_front();
      ++stats.rx_bytes_lost;
      rx_wire_free = at + cycles_per_byte();
      continue;
    }
    if (xoff) break;  // simavr's RX FIFO (63 bytes) is full: wait for XON
    rx_queue.pop_front();
    rx_wire_free = t + cycles_per_byte();
    ++stats.rx_bytes;
    avr_raise_irq(uart_irq + UART_IRQ_INPUT, item.byte);
  }
}

void Board::run_until(std::uint64_t target) {
  BoardScope scope(this);
  for (;;) {
    process_events();
    const std::uint64_t t = now();
    if (t >= target) break;
    std::uint64_t next = next_event(target);
    if (next <= t) next = t + 1;
    if (powered_off) {
      avr->cycle = next;
      continue;
    }
    const int state = avr->state;
    if (state != cpu_Running && state != cpu_Sleeping) {
      // Halted (SLEEP with interrupts off) or crashed: time passes, peripheral timers still fire (a
      // watchdog reset still reboots the MCU, the UART still finishes its last byte).
      const avr_cycle_timer_slot_p head = avr->cycle_timers.timer;
      if (head != nullptr && head->when < next) next = std::max(head->when, t);
      avr->cycle = next;
      avr_cycle_timer_process(avr);
      if (avr->run != avr_callback_run_raw) avr_run(avr);  // simavr's watchdog armed a reset: do it
      continue;
    }
    avr_cycle_timer_register(avr, next - t, stop_timer, this);
    wake = false;
    while (avr->cycle < next && !wake) {
      const std::uint64_t cycle_before = avr->cycle;
      const std::uint64_t slept_before = slept_cycles;
      avr_run(avr);
      stats.awake_cycles += (avr->cycle - cycle_before) - (slept_cycles - slept_before);
      const int after = avr->state;
      if (after != cpu_Running && after != cpu_Sleeping) break;
    }
  }
  publish();
}

void Board::move_outbound(std::uint64_t link_latency) {
  if (outbound.empty()) return;
  for (const WireItem& item : outbound) tx_peer->accept_rx(item.byte, item.start + link_latency);
  outbound.clear();
}

void Board::deliver_to_host(const std::uint8_t* data, std::size_t size) {
  if (pty) {
    pty->write_output(data, size);
    return;
  }
  {
    std::unique_lock lock(handler_mutex);
    if (handler) {
      const std::shared_ptr<OutputHandler> current = handler;
      try {
        (*current)(data, size);
      } catch (const std::exception& error) {
        std::fprintf(stderr, "virtual Uno %s: output handler threw: %s\n", options.name.c_str(), error.what());
      } catch (...) {
        std::fprintf(stderr, "virtual Uno %s: output handler threw\n", options.name.c_str());
      }
      return;
    }
  }
  {
    std::lock_guard lock(read_mutex);
    read_buffer.insert(read_buffer.end(), data, data + size);
    if (read_buffer.size() > options.host_buffer_limit) {
      const std::size_t excess = read_buffer.size() - options.host_buffer_limit;
      read_buffer.erase(read_buffer.begin(), read_buffer.begin() + static_cast<std::ptrdiff_t>(excess));
      read_discarded += excess;
    }
  }
  read_ready.notify_all();
}

// ===================================================================================================
// Group (the lockstep runner)
// ===================================================================================================

GroupImpl::~Impl() {
  if (thread.joinable()) {
    stop_requested = true;
    wake();
    thread.join();
    for (Board* member : members) member->deactivate(true);
  }
  if (wake_fd.load() >= 0) ::close(wake_fd.exchange(-1));
}

std::uint64_t GroupImpl::quantum_cycles() const {
  if (members.empty()) return 1;
  return std::max<std::uint64_t>(1, cycles_for(quantum, members.front()->options.frequency_hz));
}

void GroupImpl::wake() const {
  const int fd = wake_fd.load();
  if (fd >= 0) {
    const std::uint64_t one = 1;
    [[maybe_unused]] const ssize_t written = ::write(fd, &one, sizeof one);
  }
}

void GroupImpl::add(Board* board) {
  std::lock_guard lock(control);
  if (running()) throw std::logic_error("VirtualUnoGroup::add: the group is running");
  if (board->group.load() != nullptr) {
    throw std::logic_error(board->group.load() == board->own_group.get()
                               ? "VirtualUnoGroup::add: the board has already run on its own"
                               : "VirtualUnoGroup::add: the board is already in a group");
  }
  if (board->avr->cycle != clock) {
    throw std::logic_error("VirtualUnoGroup::add: the board and the group must not have run yet");
  }
  if (!members.empty() && members.front()->options.frequency_hz != board->options.frequency_hz) {
    throw std::logic_error("VirtualUnoGroup::add: all members must run at the same clock");
  }
  members.push_back(board);
  board->group.store(this);
}

void GroupImpl::remove(Board* board) {
  stop();
  std::lock_guard lock(control);
  members.erase(std::remove(members.begin(), members.end(), board), members.end());
  if (board->tx_peer != nullptr) board->tx_peer->rx_source = nullptr;
  if (board->rx_source != nullptr) board->rx_source->tx_peer = nullptr;
  board->tx_peer = nullptr;
  board->rx_source = nullptr;
  board->group.store(nullptr);
}

void GroupImpl::start() {
  if (sim_thread.load() == std::this_thread::get_id()) {
    throw std::logic_error("virtual Uno: start() called from the simulation thread");
  }
  std::lock_guard lock(control);
  if (thread.joinable()) return;
  for (Board* member : members) member->activate();
  wake_fd.store(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK));
  if (wake_fd.load() < 0) {
    const int error = errno;
    for (Board* member : members) member->deactivate(false);
    throw std::system_error(error, std::generic_category(), "virtual Uno: eventfd");
  }
  stop_requested = false;
  try {
    thread = std::thread([this] {
      sim_thread.store(std::this_thread::get_id());
      ::pthread_setname_np(::pthread_self(), "tether-uno");
      try {
        advance(UINT64_MAX, true);
      } catch (const std::exception& error) {
        // Keep serving accessors (the simulated state is frozen) so no caller waits for ever.
        std::fprintf(stderr, "virtual Uno: simulation stopped: %s\n", error.what());
        while (!stop_requested.load()) {
          for (Board* member : members) {
            if (member->commands_pending.exchange(false)) member->run_commands();
          }
          wait_for(std::chrono::milliseconds(10));
        }
      }
    });
    is_running = true;
  } catch (...) {
    for (Board* member : members) member->deactivate(false);
    ::close(wake_fd.exchange(-1));
    throw;
  }
}

void GroupImpl::stop() {
  if (sim_thread.load() == std::this_thread::get_id()) {
    throw std::logic_error("virtual Uno: stop()/destruction from the simulation thread (e.g. an output handler)");
  }
  std::lock_guard lock(control);
  if (!thread.joinable()) return;
  stop_requested = true;
  wake();
  thread.join();
  sim_thread.store(std::thread::id{});
  for (Board* member : members) member->deactivate(true);
  ::close(wake_fd.exchange(-1));
  is_running = false;
}

void GroupImpl::run_for(SimDuration duration) {
  if (sim_thread.load() == std::this_thread::get_id()) {
    throw std::logic_error("virtual Uno: run_for() called from the simulation thread");
  }
  std::lock_guard lock(control);
  if (running()) throw std::logic_error("virtual Uno: run_for() while a thread runs the board");
  if (members.empty()) return;
  const std::uint64_t cycles = cycles_for(duration, members.front()->options.frequency_hz);
  for (Board* member : members) member->activate();
  sim_thread.store(std::this_thread::get_id());
  struct Finish {
    GroupImpl* group;
    ~Finish() {
      group->sim_thread.store(std::thread::id{});
      for (Board* member : group->members) member->deactivate(false);
    }
  } finish{this};
  stop_requested = false;
  advance(clock + cycles, false);
}

void GroupImpl::wait_for(std::chrono::nanoseconds duration) {
  std::vector<pollfd> fds;
  const int wake_descriptor = wake_fd.load();
  fds.push_back(pollfd{wake_descriptor, POLLIN, 0});
  for (Board* member : members) {
    if (member->pty) fds.push_back(pollfd{member->pty->master_fd(), POLLIN, 0});
  }
  timespec timeout{};
  timeout.tv_sec = static_cast<time_t>(duration.count() / 1'000'000'000);
  timeout.tv_nsec = static_cast<long>(duration.count() % 1'000'000'000);
  const int ready = ::ppoll(fds.data(), fds.size(), &timeout, nullptr);
  if (ready <= 0) return;
  if ((fds[0].revents & POLLIN) != 0) {
    std::uint64_t count = 0;
    [[maybe_unused]] const ssize_t got = ::read(wake_descriptor, &count, sizeof count);
  }
  std::size_t index = 1;
  for (Board* member : members) {
    if (member->pty) {
      if (fds[index].revents != 0) member->pty_poll_due = true;
      ++index;
    }
  }
}

void GroupImpl::advance(std::uint64_t end, bool threaded) {
  if (members.empty()) return;
  const std::uint64_t q = quantum_cycles();
  const std::uint32_t frequency = members.front()->options.frequency_hz;
  const bool paced = threaded && pacing == Pacing::real_time;
  auto wall_origin = std::chrono::steady_clock::now();
  const std::uint64_t clock_origin = clock;
  auto last_pty_poll = wall_origin;
  while (clock < end && !stop_requested.load(std::memory_order_relaxed)) {
    const std::uint64_t target = end - clock > q ? clock + q : end;
    const auto wall_now = std::chrono::steady_clock::now();
    const bool poll_pty = wall_now - last_pty_poll >= std::chrono::milliseconds(1);
    if (poll_pty) last_pty_poll = wall_now;
    for (Board* member : members) member->begin_quantum(poll_pty);
    for (Board* member : members) member->run_until(target);
    for (Board* member : members) member->move_outbound(q);
    clock = target;
    if (paced) {
      const auto simulated = duration_for(clock - clock_origin, frequency);
      const auto wall = std::chrono::steady_clock::now() - wall_origin;
      if (simulated - wall > std::chrono::microseconds(500)) {
        wait_for(std::chrono::duration_cast<std::chrono::nanoseconds>(simulated - wall));
      } else if (wall - simulated > std::chrono::milliseconds(100)) {
        wall_origin = std::chrono::steady_clock::now() -
                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(simulated);
      }
    }
  }
}

// ===================================================================================================
// VirtualUno
// ===================================================================================================

VirtualUno::VirtualUno(VirtualUnoOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {}

std::unique_ptr<VirtualUno> VirtualUno::create(VirtualUnoOptions options, std::error_code& error,
                                               std::string* message) noexcept {
  error.clear();
  try {
    return std::make_unique<VirtualUno>(std::move(options));
  } catch (const std::system_error& failure) {
    error = failure.code();
    if (message != nullptr) *message = failure.what();
  } catch (const std::invalid_argument& failure) {
    error = std::make_error_code(std::errc::invalid_argument);
    if (message != nullptr) *message = failure.what();
  } catch (const std::exception& failure) {
    error = std::make_error_code(std::errc::not_enough_memory);
    if (message != nullptr) *message = failure.what();
  }
  return nullptr;
}

VirtualUno::~VirtualUno() {
  if (!impl_) return;
  GroupImpl* owner = impl_->group.load();
  if (owner != nullptr && owner != impl_->own_group.get()) {
    owner->remove(impl_.get());
  } else if (impl_->own_group) {
    impl_->own_group->stop();
    impl_->group.store(nullptr);
    impl_->own_group.reset();
  }
}

namespace {

GroupImpl& own_group_of(Board& board) {
  GroupImpl* owner = board.group.load();
  if (owner != nullptr) return *owner;
  board.own_group = std::make_unique<GroupImpl>(board.options.pacing, board.options.quantum);
  board.own_group->clock = board.avr->cycle;
  board.own_group->add(&board);
  return *board.own_group;
}

}  // namespace

void VirtualUno::start() {
  GroupImpl* owner = impl_->group.load();
  if (owner != nullptr && owner != impl_->own_group.get()) {
    throw std::logic_error("virtual Uno: the board is a member of a VirtualUnoGroup: start the group");
  }
  own_group_of(*impl_).start();
}

void VirtualUno::stop() {
  if (GroupImpl* owner = impl_->group.load()) owner->stop();
}

bool VirtualUno::running() const {
  const GroupImpl* owner = impl_->group.load();
  return owner != nullptr && owner->running();
}

void VirtualUno::run_for(SimDuration duration) { own_group_of(*impl_).run_for(duration); }

void VirtualUno::write(std::span<const std::uint8_t> bytes) {
  if (bytes.empty()) return;
  std::lock_guard lock(impl_->host_in_mutex);
  impl_->host_in.insert(impl_->host_in.end(), bytes.begin(), bytes.end());
  impl_->host_in_pending.store(true, std::memory_order_release);
}

void VirtualUno::write(std::string_view text) {
  write(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

std::size_t VirtualUno::read(std::span<std::uint8_t> buffer, std::chrono::milliseconds timeout) {
  if (buffer.empty()) return 0;
  std::unique_lock lock(impl_->read_mutex);
  if (!impl_->read_ready.wait_for(lock, timeout, [this] { return !impl_->read_buffer.empty(); })) return 0;
  const std::size_t count = std::min(buffer.size(), impl_->read_buffer.size());
  std::copy_n(impl_->read_buffer.begin(), count, buffer.begin());
  impl_->read_buffer.erase(impl_->read_buffer.begin(), impl_->read_buffer.begin() + static_cast<std::ptrdiff_t>(count));
  return count;
}

std::size_t VirtualUno::available() const {
  std::lock_guard lock(impl_->read_mutex);
  return impl_->read_buffer.size();
}

void VirtualUno::set_output_handler(OutputHandler handler) {
  std::shared_ptr<OutputHandler> next;
  if (handler) next = std::make_shared<OutputHandler>(std::move(handler));
  std::lock_guard lock(impl_->handler_mutex);
  impl_->handler.swap(next);
}

std::string VirtualUno::open_pty() {
  std::error_code error;
  std::string path = open_pty(error);
  if (error) throw std::system_error(error, "virtual Uno " + impl_->options.name + ": cannot open a pty");
  return path;
}

std::string VirtualUno::open_pty(std::error_code& error) {
  error.clear();
  return impl_->execute([this, &error]() -> std::string {
    if (impl_->pty) return impl_->pty->path();
    auto pty = detail::Pty::open(impl_->options.pty_baud, error);
    if (!pty) return {};
    if (impl_->options.reset_on_open && !pty->watch_opens(error)) return {};
    std::string path = pty->path();
    impl_->pty = std::move(pty);
    return path;
  });
}

std::optional<std::string> VirtualUno::pty_path() const {
  return impl_->execute([this]() -> std::optional<std::string> {
    if (impl_->pty) return impl_->pty->path();
    return std::nullopt;
  });
}

std::uint64_t VirtualUno::cycles() const {
  if (impl_->on_sim_thread()) return impl_->avr->cycle;
  return impl_->published_cycles.load(std::memory_order_relaxed);
}

SimDuration VirtualUno::simulated_time() const { return to_duration(cycles()); }
std::uint32_t VirtualUno::frequency_hz() const { return impl_->options.frequency_hz; }
std::uint64_t VirtualUno::to_cycles(SimDuration duration) const { return cycles_for(duration, impl_->options.frequency_hz); }
SimDuration VirtualUno::to_duration(std::uint64_t count) const { return duration_for(count, impl_->options.frequency_hz); }

void VirtualUno::set_faults(Direction direction, const FaultConfig& config) {
  config.validate();
  impl_->execute([this, direction, &config] {
    (direction == Direction::to_mcu ? impl_->to_mcu_faults : impl_->from_mcu_faults).set_config(config);
  });
}

void VirtualUno::reset(ResetKind kind, SimDuration off_for) {
  impl_->execute([this, kind, off_for] {
    impl_->scheduled_resets.emplace(impl_->now(), Impl::ScheduledReset{kind, to_cycles(off_for)});
    impl_->wake = true;
  });
}

void VirtualUno::schedule_reset(ResetKind kind, SimDuration at, SimDuration off_for) {
  const std::uint64_t when = to_cycles(at);
  impl_->execute([this, kind, when, off_for] {
    impl_->scheduled_resets.emplace(std::max(when, impl_->now()), Impl::ScheduledReset{kind, to_cycles(off_for)});
    impl_->wake = true;
  });
}

VirtualUnoStats VirtualUno::stats() const {
  VirtualUnoStats result = impl_->execute([this] {
    VirtualUnoStats copy = impl_->stats;
    copy.to_mcu = impl_->to_mcu_faults.counts();
    copy.from_mcu = impl_->from_mcu_faults.counts();
    if (impl_->pty) copy.host_bytes_discarded += impl_->pty->discarded();
    return copy;
  });
  std::lock_guard lock(impl_->read_mutex);
  result.host_bytes_discarded += impl_->read_discarded;
  return result;
}

PinState VirtualUno::pin(int arduino_pin) const {
  const auto [port, bit] = locate(arduino_pin);
  return impl_->execute([this, port = port, bit = bit] {
    const avr_t* avr = impl_->avr;
    const auto mask = static_cast<std::uint8_t>(1u << bit);
    PinState state;
    if (port == 2 && bit == 0 && impl_->rx_enabled()) {
      state.level = true;  // the host's TX line idles high
      state.uart = true;
      return state;
    }
    if (port == 2 && bit == 1 && impl_->tx_enabled()) {
      state.level = true;  // the UART's TX idles high
      state.output = true;
      state.uart = true;
      return state;
    }
    state.output = (avr->data[kDdrAddress[port]] & mask) != 0;
    if (state.output) {
      state.level = impl_->edges[port][bit].level;  // PORT, or a timer's compare output
    } else if ((impl_->driven_mask[port] & mask) != 0) {
      state.level = (impl_->driven_value[port] & mask) != 0;
    } else {
      state.pull_up = (avr->data[kPortAddress[port]] & mask) != 0;
      state.level = state.pull_up;
      state.floating = !state.pull_up;
    }
    return state;
  });
}

bool VirtualUno::digital_level(int arduino_pin) const { return pin(arduino_pin).level; }

PortRegisters VirtualUno::port(char name) const {
  const int index = port_index(name);
  return impl_->execute([this, index] {
    const avr_t* avr = impl_->avr;
    return PortRegisters{avr->data[kPortAddress[index]], avr->data[kDdrAddress[index]], avr->data[kPinAddress[index]]};
  });
}

void VirtualUno::set_input_level(int arduino_pin, bool level) {
  const auto [port, bit] = locate(arduino_pin);
  impl_->execute([this, port = port, bit = bit, level] {
    const auto mask = static_cast<std::uint8_t>(1u << bit);
    impl_->driven_mask[port] = static_cast<std::uint8_t>(impl_->driven_mask[port] | mask);
    impl_->driven_value[port] = static_cast<std::uint8_t>(level ? impl_->driven_value[port] | mask
                                                                : impl_->driven_value[port] & ~mask);
    avr_raise_irq(impl_->port_irq[port] + bit, level ? 1 : 0);
  });
}

void VirtualUno::release_input(int arduino_pin) {
  const auto [port, bit] = locate(arduino_pin);
  impl_->execute([this, port = port, bit = bit] {
    const auto mask = static_cast<std::uint8_t>(1u << bit);
    impl_->driven_mask[port] = static_cast<std::uint8_t>(impl_->driven_mask[port] & ~mask);
    const bool pull_up = (impl_->avr->data[kPortAddress[port]] & mask) != 0;
    avr_raise_irq(impl_->port_irq[port] + bit, pull_up ? 1 : 0);
  });
}

void VirtualUno::set_analog_input(int channel, double volts) {
  if (channel < 0 || channel > 7) {
    throw std::out_of_range("virtual Uno: no ADC channel " + std::to_string(channel) + " (0..7)");
  }
  if (!(volts >= 0.0 && volts <= 5.5)) throw std::invalid_argument("virtual Uno: analog input must be 0..5.5 V");
  const auto millivolts = static_cast<std::uint32_t>(std::lround(volts * 1000.0));
  impl_->execute([this, channel, millivolts] {
    avr_raise_irq(impl_->adc_irq + ADC_IRQ_ADC0 + channel, millivolts);
  });
}

PulseTiming VirtualUno::pulse_timing(int arduino_pin) const {
  const auto [port, bit] = locate(arduino_pin);
  const Impl::EdgeRecord record = impl_->execute([this, port = port, bit = bit] { return impl_->edges[port][bit]; });
  PulseTiming timing;
  timing.edges = record.edges;
  timing.level = record.level;
  timing.last_edge = to_duration(record.last_edge);
  timing.high_time = to_duration(record.high);
  timing.period = to_duration(record.period);
  return timing;
}

Timer1Registers VirtualUno::timer1() const {
  return impl_->execute([this] {
    avr_t* avr = impl_->avr;
    // simavr computes TCNT1 when the CPU reads TCNT1L; do the same (it only refreshes TCNT1L/H).
    const auto& counter = avr->io[AVR_DATA_TO_IO(reg::TCNT1L)];
    if (counter.r.c != nullptr) counter.r.c(avr, reg::TCNT1L, counter.r.param);
    const std::uint8_t* data = avr->data;
    auto word = [data](std::uint16_t low) {
      return static_cast<std::uint16_t>(data[low] | (data[low + 1] << 8));
    };
    return Timer1Registers{data[reg::TCCR1A], data[reg::TCCR1B], word(reg::TCNT1L),
                           word(reg::OCR1AL), word(reg::OCR1BL), word(reg::ICR1L)};
  });
}

UartStatus VirtualUno::uart() const {
  return impl_->execute([this] {
    const std::uint8_t* data = impl_->avr->data;
    UartStatus status;
    status.rx_enabled = impl_->rx_enabled();
    status.tx_enabled = impl_->tx_enabled();
    status.cycles_per_byte = impl_->cycles_per_byte();
    const unsigned ubrr = static_cast<unsigned>(((data[reg::UBRR0H] & 0x0F) << 8) | data[reg::UBRR0L]);
    const unsigned divisor = (ubrr + 1) * ((data[reg::UCSR0A] & 0x02) != 0 ? 8u : 16u);
    status.baud = impl_->options.frequency_hz / divisor;
    return status;
  });
}

CpuState VirtualUno::cpu_state() const {
  return impl_->execute([this] {
    if (impl_->powered_off) return CpuState::powered_off;
    switch (impl_->avr->state) {
      case cpu_Running: return CpuState::running;
      case cpu_Sleeping: return CpuState::sleeping;
      case cpu_Done: return CpuState::halted;
      default: return CpuState::crashed;
    }
  });
}

std::vector<std::uint8_t> VirtualUno::read_memory(std::uint16_t address, std::size_t length) const {
  if (static_cast<std::size_t>(address) + length > static_cast<std::size_t>(impl_->avr->ramend) + 1) {
    throw std::out_of_range("virtual Uno: read_memory beyond RAMEND");
  }
  return impl_->execute([this, address, length] {
    const std::uint8_t* data = impl_->avr->data + address;
    return std::vector<std::uint8_t>(data, data + length);
  });
}

void VirtualUno::write_memory(std::uint16_t address, std::span<const std::uint8_t> bytes) {
  if (static_cast<std::size_t>(address) + bytes.size() > static_cast<std::size_t>(impl_->avr->ramend) + 1) {
    throw std::out_of_range("virtual Uno: write_memory beyond RAMEND");
  }
  impl_->execute([this, address, bytes] { std::copy(bytes.begin(), bytes.end(), impl_->avr->data + address); });
}

void VirtualUno::write_eeprom(std::uint16_t address, std::span<const std::uint8_t> bytes) {
  if (static_cast<std::size_t>(address) + bytes.size() > reg::kEepromSize) {
    throw std::out_of_range("virtual Uno: write_eeprom beyond the 1 KiB EEPROM");
  }
  if (bytes.empty()) return;
  impl_->execute([this, address, bytes] {
    // simavr copies from `ee`; the ioctl's parameter is not const-qualified.
    std::vector<std::uint8_t> copy(bytes.begin(), bytes.end());
    avr_eeprom_desc_t descriptor{copy.data(), address, static_cast<std::uint32_t>(copy.size())};
    // simavr 1.6 answers -1 on success (so other modules get their turn) and -2 on a bad argument.
    if (avr_ioctl(impl_->avr, AVR_IOCTL_EEPROM_SET, &descriptor) == -2) {
      throw std::out_of_range("virtual Uno: libsimavr refused the EEPROM write");
    }
  });
}

std::vector<std::uint8_t> VirtualUno::read_eeprom(std::uint16_t address, std::size_t length) const {
  if (static_cast<std::size_t>(address) + length > reg::kEepromSize) {
    throw std::out_of_range("virtual Uno: read_eeprom beyond the 1 KiB EEPROM");
  }
  if (length == 0) return {};
  return impl_->execute([this, address, length] {
    std::vector<std::uint8_t> bytes(length);
    avr_eeprom_desc_t descriptor{bytes.data(), address, static_cast<std::uint32_t>(length)};
    if (avr_ioctl(impl_->avr, AVR_IOCTL_EEPROM_GET, &descriptor) == -2) {
      throw std::out_of_range("virtual Uno: libsimavr refused the EEPROM read");
    }
    return bytes;
  });
}

std::optional<FirmwareSymbol> VirtualUno::symbol(std::string_view name) const {
  // Constant after construction: no need to go through the simulation thread.
  const auto found = impl_->symbols.find(std::string(name));
  if (found == impl_->symbols.end()) return std::nullopt;
  return found->second;
}

std::uint8_t VirtualUno::io_read(std::uint16_t address) {
  if (address < 0x20 || address > impl_->avr->ioend) throw std::out_of_range("virtual Uno: io_read outside the I/O space");
  return impl_->execute([this, address] {
    avr_t* avr = impl_->avr;
    const auto& slot = avr->io[AVR_DATA_TO_IO(address)];
    if (slot.r.c != nullptr) return slot.r.c(avr, address, slot.r.param);
    return avr->data[address];
  });
}

void VirtualUno::io_write(std::uint16_t address, std::uint8_t value) {
  if (address < 0x20 || address > impl_->avr->ioend || address == reg::SREG) {
    throw std::out_of_range("virtual Uno: io_write outside the I/O space (SREG excluded)");
  }
  impl_->execute([this, address, value] {
    avr_t* avr = impl_->avr;
    const auto& slot = avr->io[AVR_DATA_TO_IO(address)];
    if (slot.w.c != nullptr) {
      slot.w.c(avr, address, value, slot.w.param);
    } else {
      avr->data[address] = value;
    }
  });
}

void Board::IoWatch::record(std::uint8_t value, bool is_write) {
  if (accesses.size() < limit) {
    accesses.push_back(IoAccess{board->now(), value, is_write});
  } else {
    ++dropped;
  }
}

std::uint8_t Board::on_watched_read(avr_t* avr, avr_io_addr_t address, void* param) {
  auto* watch = static_cast<IoWatch*>(param);
  const std::uint8_t value = watch->read != nullptr ? watch->read(avr, address, watch->read_param) : avr->data[address];
  watch->record(value, false);
  return value;
}

void Board::on_watched_write(avr_t* avr, avr_io_addr_t address, std::uint8_t value, void* param) {
  auto* watch = static_cast<IoWatch*>(param);
  watch->record(value, true);
  if (watch->write != nullptr) {
    watch->write(avr, address, value, watch->write_param);
  } else {
    avr->data[address] = value;
  }
}

void VirtualUno::watch_io(std::uint16_t address, std::size_t limit) {
  if (address < 0x20 || address > impl_->avr->ioend || address == reg::SREG) {
    throw std::out_of_range("virtual Uno: watch_io outside the I/O space (SREG excluded)");
  }
  impl_->execute([this, address, limit] {
    auto& slot = impl_->avr->io[AVR_DATA_TO_IO(address)];
    auto& watch = impl_->io_watches[address];
    if (!watch) {
      // simavr keeps one handler per register: ours takes the slot and calls the one it replaces.
      watch = std::make_unique<Impl::IoWatch>(
          Impl::IoWatch{impl_.get(), address, slot.r.c, slot.r.param, slot.w.c, slot.w.param, limit, {}, 0});
      slot.r.c = &Impl::on_watched_read;
      slot.r.param = watch.get();
      slot.w.c = &Impl::on_watched_write;
      slot.w.param = watch.get();
    }
    watch->limit = limit;
    watch->accesses.clear();
    watch->dropped = 0;
  });
}

std::vector<IoAccess> VirtualUno::io_accesses(std::uint16_t address) const {
  return impl_->execute([this, address] {
    const auto found = impl_->io_watches.find(address);
    return found == impl_->io_watches.end() ? std::vector<IoAccess>{} : found->second->accesses;
  });
}

std::uint64_t VirtualUno::io_accesses_dropped(std::uint16_t address) const {
  return impl_->execute([this, address] {
    const auto found = impl_->io_watches.find(address);
    return found == impl_->io_watches.end() ? std::uint64_t{0} : found->second->dropped;
  });
}

const VirtualUnoOptions& VirtualUno::options() const { return impl_->options; }

// ===================================================================================================
// VirtualUnoGroup
// ===================================================================================================

VirtualUnoGroup::VirtualUnoGroup(Pacing pacing, SimDuration quantum) : impl_(std::make_unique<Impl>(pacing, quantum)) {
  if (quantum.count() <= 0) throw std::invalid_argument("VirtualUnoGroup: quantum must be positive");
}

VirtualUnoGroup::~VirtualUnoGroup() {
  impl_->stop();
  std::lock_guard lock(impl_->control);
  for (Board* member : impl_->members) {
    member->tx_peer = nullptr;
    member->rx_source = nullptr;
    member->group.store(nullptr);
  }
  impl_->members.clear();
}

void VirtualUnoGroup::add(VirtualUno& board) { impl_->add(board.impl_.get()); }

void VirtualUnoGroup::connect(VirtualUno& from, VirtualUno& to) {
  std::lock_guard lock(impl_->control);
  Board* sender = from.impl_.get();
  Board* receiver = to.impl_.get();
  if (impl_->running()) throw std::logic_error("VirtualUnoGroup::connect: the group is running");
  if (sender->group.load() != impl_.get() || receiver->group.load() != impl_.get()) {
    throw std::logic_error("VirtualUnoGroup::connect: both boards must be members of this group");
  }
  if (sender->tx_peer != nullptr) throw std::logic_error("VirtualUnoGroup::connect: that TX is already wired");
  if (receiver->rx_source != nullptr) throw std::logic_error("VirtualUnoGroup::connect: that RX is already wired");
  sender->tx_peer = receiver;
  receiver->rx_source = sender;
}

void VirtualUnoGroup::start() { impl_->start(); }
void VirtualUnoGroup::stop() { impl_->stop(); }
bool VirtualUnoGroup::running() const { return impl_->running(); }
void VirtualUnoGroup::run_for(SimDuration duration) { impl_->run_for(duration); }
SimDuration VirtualUnoGroup::quantum() const { return impl_->quantum; }
Pacing VirtualUnoGroup::pacing() const { return impl_->pacing; }

}  // namespace tether::transports
