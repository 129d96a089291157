/// @file virtual_uno.hpp
/// A virtual Arduino Uno: an ELF image running on a simulated ATmega328P at 16 MHz (libsimavr 1.6), with
/// its UART0 bridged to the host as an in-process byte stream and/or a pseudo-terminal, fault injection
/// on the bridged bytes, access to pins, timers and the ADC, and wiring of several boards into a ring.
///
/// ## Threads and pacing
/// A board runs on a simulation thread: its own (`VirtualUno::start()`) or the one of the lockstep group
/// it belongs to (`VirtualUnoGroup::start()`). Alternatively `run_for()` advances the simulation on the
/// calling thread (no thread at all: deterministic tests and benchmarks). "The simulation thread" below
/// means whichever thread is currently advancing the board.
///
/// - `Pacing::real_time`: simulated time follows the wall clock (the thread sleeps while it is ahead;
///   if the host cannot keep up it runs as fast as it can and re-synchronises after a 100 ms lag instead
///   of bursting to catch up).
/// - `Pacing::fast`: as fast as possible; simulated time is decoupled from wall time. A fast thread uses
///   a whole core. Measured with tether_virtual_uno_benchmarks (2-core dev machine, RelWithDebInfo):
///   echo.elf idle ~740x real time, echo.elf at full line rate both ways ~17x, firmware that never
///   sleeps (selftest's polling loops) ~5.8x (~93 simulated MHz), two idle boards in lockstep ~250x.
///
/// Accessors that look at the simulated MCU (pins, registers, stats, faults, resets) are thread-safe:
/// while a thread runs the board they are queued and executed by that thread at the next quantum
/// boundary (the caller waits, at most one quantum of simulation), otherwise they run at once. A CPU
/// that halts (SLEEP with interrupts off, or a crash) keeps its peripherals and time running; only a
/// reset (injected, or simavr's watchdog) wakes it.
///
/// ## Time model
/// Simulated time is the CPU cycle count divided by the clock (`cycles()`, `simulated_time()`), counted
/// from the board's creation; it also runs while the CPU sleeps or is halted. Both are atomics readable
/// from any thread; off the simulation thread they are updated at every quantum boundary (so at most one
/// quantum old), on the simulation thread (e.g. inside the output handler) they are exact.
///
/// The simulation advances in quanta (default 1 ms simulated for a single board, 64 us for a group).
/// Inside a quantum every UART event happens at its exact cycle; host input (`write()`, the pty) and
/// commands (pin access, resets, fault changes) are taken at quantum boundaries.
///
/// ## UART timing: 11 bits per byte
/// simavr 1.6 paces its UART at `cycles_per_byte = (UBRR+1) * (U2X ? 8 : 16) * 11` CPU cycles: a start
/// bit, 8 data bits, one parity bit (counted even when parity is off) and a stop bit. At 115200 baud
/// (UBRR0=16, U2X0=1, really 117647 bit/s) that is 1496 cycles = 93.5 us per byte, ~10.7 kB/s. The bridge
/// honours the same figure both ways:
/// - MCU -> host: a byte written to UDR0 at cycle t goes on the wire at `start = max(t, end of previous
///   byte)` and reaches the host (or the next board) one byte time later, at `start + cycles_per_byte`.
/// - host -> MCU: queued bytes enter the UART one per `cycles_per_byte`; simavr raises RXC one byte time
///   after a byte enters, so a byte written by the host is readable by the firmware ~1 byte time later.
///   Injection respects simavr's flow control: it pauses on UART_IRQ_OUT_XOFF (RX FIFO full: 63 bytes)
///   and resumes on XON, so no byte is lost to an overrun. Bytes arriving while the receiver is disabled
///   (RXEN0=0: during boot, reset or power-off) are lost, as on a real board; they are counted in
///   `VirtualUnoStats::rx_bytes_lost`. Write only after the firmware is up (e.g. after its banner).
///
/// ## Lockstep groups (rings of boards)
/// `VirtualUnoGroup` runs several boards on one thread in lockstep: every member advances to the same
/// quantum boundary before any goes further. A byte a board transmits towards another board (its TX
/// wired with `connect()`) starts arriving at the receiver exactly one quantum (the link latency) after
/// it started on the wire, which is always in the receiver's future: the outcome depends only on the
/// firmware and the inputs, never on thread scheduling. Board-to-board traffic is deterministic; host
/// input is taken at quantum boundaries, so it is deterministic too when driven through `run_for()`.
/// A host sits in a ring by writing to the first board (`write()`) and reading from the last (a board
/// whose TX is not wired delivers to the host).
///
/// ## Host side of the stream
/// Bytes the MCU transmits (after faults) go to exactly one place, first match wins:
///   1. the pty, while one is open (`open_pty()`);
///   2. the output handler, while one is set (`set_output_handler()`);
///   3. the read buffer (`read()`), bounded by `VirtualUnoOptions::host_buffer_limit` (oldest bytes are
///      discarded and counted when nobody reads).
/// Host input from `write()` and from the pty is merged in arrival order.
///
/// The output handler is the primary path for asynchronous consumers (an asio adapter): it is called on
/// the simulation thread for each batch of received bytes, at the simulated instant the batch's last stop
/// bit ends. Contract: it must not block, and must not call `stop()`, `run_for()`, a destructor or
/// `VirtualUnoGroup::start/stop` (they throw std::logic_error from the simulation thread); it may call
/// `write()`, `set_output_handler()` (to replace or clear itself), the time getters, `stats()` and the
/// pin/register accessors (they run inline). `set_output_handler()` from another thread waits for a
/// running invocation to finish: once it returns, the previous handler is never called again.
///
/// ## Faults (see fault_model.hpp)
/// Each direction has its own `FaultModel` (bit errors, drops, duplicates, extra latency in simulated
/// time), seeded from `VirtualUnoOptions::seed`: the same seed, firmware and inputs give the same faults.
/// Faults apply per byte: a byte is dropped, corrupted or doubled as it passes, and its extra latency
/// (drawn per byte) delays it in simulated time without ever reordering the stream.
/// Direction::to_mcu applies to every byte entering the board's RX (from the host or a wired board),
/// Direction::from_mcu to every byte its TX sends. Resets are board-level faults:
/// - `ResetKind::watchdog`: like a watchdog timeout: RAM and registers kept, MCUSR |= WDRF (flags add up
///   until the firmware clears them, as on the part). Unlike a real watchdog reset the watchdog is not
///   left armed (simavr does arm it for a firmware-triggered one).
/// - `ResetKind::external`: the RESET pin (the Uno's button, or DTR): RAM kept, MCUSR |= EXTRF.
/// - `ResetKind::power_cycle`: power off for `off_for` (the CPU stops, RX bytes are lost), then power on:
///   SRAM and the register file filled with seeded random data (as real SRAM powers up), MCUSR = PORF.
///   EEPROM and flash are kept.
/// A firmware-triggered watchdog reset (`wdt_enable()` then a loop) reboots the board through simavr's
/// own watchdog, which also sets WDRF and leaves the watchdog armed at 16 ms like the hardware does.
///
/// ## Pins
/// Arduino pin numbers: D0..D13 (PD0..PD7, PB0..PB5) and A0..A5 = 14..19 (PC0..PC5). simavr does not
/// model the UART's takeover of PD0/PD1; this class reports D1 as an output at idle high while TXEN0 is
/// set and D0 as an input held high by the host's idle line while RXEN0 is set. Timer1's compare outputs
/// ARE driven by simavr 1.6: in fast PWM with ICR1 as TOP (servo mode 14, COM1x1) OC1A/OC1B on PB1/PB2
/// (D9/D10) go high at BOTTOM and low at the compare match, so `pulse_timing(9)` measures a servo pulse (1.5005 ms high every 20 ms for OCR1A = 3000,
/// ICR1 = 39999, /8). Pulse timing records every change of a pin's level as seen by simavr's ioport IRQs,
/// stamped with the cycle at which simavr raised the IRQ: exact to within the instruction that was
/// executing (a few cycles). simavr models PWM only through these pin IRQs; the timer registers
/// (`timer1()`) are the other way to read a servo's setting.
///
/// ## EEPROM and firmware symbols
/// `write_eeprom`/`read_eeprom` reach the 1 KiB EEPROM through simavr's ioctl (a programmer's view: no
/// write delay, no wear). It starts erased (0xFF) or with the image's .eeprom section and survives every
/// reset and power cycle, so a test configures a board before its first `run_for()` and the firmware
/// finds the bytes at boot. `symbol(name)` gives the address of a firmware global from the image's
/// ELF symbol table, so tests read firmware state with `read_memory` at an address that follows the
/// build instead of a hard-coded one.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "tether/transports/fault_model.hpp"

namespace tether::transports {

/// Simulated time (nanoseconds, from the board's creation).
using SimDuration = std::chrono::nanoseconds;

/// How simulated time relates to wall time.
enum class Pacing { real_time, fast };

/// Board-level faults (see the file comment).
enum class ResetKind { watchdog, external, power_cycle };

/// A direction of the bridged UART.
enum class Direction {
  to_mcu,    ///< bytes entering the board's RX (from the host or a wired board)
  from_mcu,  ///< bytes leaving the board's TX
};

/// What the simulated CPU is doing.
enum class CpuState {
  running,
  sleeping,     ///< SLEEP with interrupts enabled: wakes on an interrupt
  halted,       ///< SLEEP with interrupts disabled: only a reset wakes it
  crashed,      ///< simavr stopped the core (bad opcode, bad jump...)
  powered_off,  ///< inside a power cycle's off time
};

/// Arduino Uno pin numbers.
namespace uno_pins {
inline constexpr int D0 = 0, D1 = 1, D2 = 2, D3 = 3, D4 = 4, D5 = 5, D6 = 6, D7 = 7, D8 = 8, D9 = 9, D10 = 10,
                     D11 = 11, D12 = 12, D13 = 13, A0 = 14, A1 = 15, A2 = 16, A3 = 17, A4 = 18, A5 = 19;
inline constexpr int kCount = 20;
}  // namespace uno_pins

/// ATmega328P data-space addresses of the registers the accessors deal with (for `read_memory`,
/// `io_read`, `io_write`).
namespace atmega328p {
inline constexpr std::uint16_t PINB = 0x23, DDRB = 0x24, PORTB = 0x25, PINC = 0x26, DDRC = 0x27, PORTC = 0x28,
                               PIND = 0x29, DDRD = 0x2A, PORTD = 0x2B, GPIOR0 = 0x3E, SREG = 0x5F, MCUSR = 0x54, WDTCSR = 0x60,
                               ADCL = 0x78, ADCH = 0x79, ADCSRA = 0x7A, ADCSRB = 0x7B, ADMUX = 0x7C, TCCR1A = 0x80,
                               TCCR1B = 0x81, TCNT1L = 0x84, TCNT1H = 0x85, ICR1L = 0x86, ICR1H = 0x87,
                               OCR1AL = 0x88, OCR1AH = 0x89, OCR1BL = 0x8A, OCR1BH = 0x8B, UCSR0A = 0xC0,
                               UCSR0B = 0xC1, UCSR0C = 0xC2, UBRR0L = 0xC4, UBRR0H = 0xC5, UDR0 = 0xC6;
/// First SRAM address and the last one (RAMEND).
inline constexpr std::uint16_t kSramStart = 0x100, kRamEnd = 0x8FF;
/// EEPROM size in bytes (addresses 0 .. 0x3FF).
inline constexpr std::uint16_t kEepromSize = 1024;
/// MCUSR bits.
inline constexpr std::uint8_t PORF = 0x01, EXTRF = 0x02, BORF = 0x04, WDRF = 0x08;
}  // namespace atmega328p

/// Errors of the virtual Uno that are not OS errors (those come as std::errc / system_category codes).
enum class VirtualUnoError {
  not_an_avr_elf = 1,   ///< the file is not a 32-bit little-endian ELF for the AVR
  firmware_too_large,   ///< .text + .data do not fit the 32 KiB flash
  simulator_failed,     ///< libsimavr could not create or initialise the MCU
  bad_bootloader,       ///< VirtualUnoOptions::bootloader is not Intel HEX for a boot section of the part
};
const std::error_category& virtual_uno_category();
std::error_code make_error_code(VirtualUnoError error);

struct VirtualUnoOptions {
  /// The ELF image to run (avr-gcc output for the ATmega328P). May be empty when `bootloader` is set: a
  /// board whose application flash is blank until something is uploaded through the bootloader.
  std::filesystem::path firmware{};
  /// Intel HEX of a bootloader (Debian's arduino-core-avr: `bootloaders/optiboot/optiboot_atmega328.hex`)
  /// written into the boot section, with the reset vector there (BOOTRST programmed, as on an Uno): every
  /// reset starts it. What it writes with SPM (an uploaded application) stays in flash across resets, so
  /// optiboot's watchdog reset into the new application works. Empty: resets start the image at 0.
  std::filesystem::path bootloader{};
  /// Reset the board (ResetKind::external, MCUSR EXTRF) whenever a client opens its pty, as an Uno's DTR
  /// line does through its auto-reset capacitor (a pty carries no modem lines, so the open stands for the
  /// DTR edge). With optiboot this is what makes avrdude find the bootloader. Needs `open_pty()`.
  bool reset_on_open = false;
  /// Pacing when the board runs on its own thread (a group has its own).
  Pacing pacing = Pacing::real_time;
  /// Quantum when the board runs on its own thread or through its own `run_for()`.
  SimDuration quantum = std::chrono::milliseconds(1);
  /// CPU clock.
  std::uint32_t frequency_hz = 16'000'000;
  /// Faults of each direction (can be changed later with `set_faults()`).
  FaultConfig to_mcu_faults{};
  FaultConfig from_mcu_faults{};
  /// Seed of the fault models and of the power-up RAM contents.
  std::uint64_t seed = 0;
  /// Bound of the read buffer (bytes nobody has read yet).
  std::size_t host_buffer_limit = std::size_t{1} << 20;
  /// Line speed the pty reports to its clients (a pty has no real baud rate; cosmetic).
  std::uint32_t pty_baud = 115200;
  /// Name used in messages (default: the firmware's file name).
  std::string name{};
};

/// UART0 as the firmware configured it.
struct UartStatus {
  bool rx_enabled = false;
  bool tx_enabled = false;
  std::uint32_t baud = 0;              ///< the real bit rate (e.g. 117647 for "115200" with U2X)
  std::uint64_t cycles_per_byte = 0;   ///< what simavr paces a byte with (11 bits)
};

/// PORTx, DDRx and PINx of one port (raw register contents).
struct PortRegisters {
  std::uint8_t port = 0;
  std::uint8_t ddr = 0;
  std::uint8_t pin = 0;
};

/// The state of one Arduino pin.
struct PinState {
  bool level = false;     ///< what a voltmeter would read (a floating input reads low)
  bool output = false;    ///< driven by the MCU
  bool pull_up = false;   ///< input with the internal pull-up on
  bool floating = false;  ///< input with no pull-up and nothing driving it
  bool uart = false;      ///< taken over by UART0 (D0 with RXEN0, D1 with TXEN0)
};

/// Transitions of one pin, in simulated time (exact cycles).
struct PulseTiming {
  std::uint64_t edges = 0;  ///< level changes seen since the board was created
  bool level = false;       ///< current level
  SimDuration last_edge{};  ///< when the last change happened
  SimDuration high_time{};  ///< duration of the last complete high pulse (0 until one completed)
  SimDuration period{};     ///< rising edge to rising edge, last complete period (0 until one completed)
};

/// Timer1 registers (the servo timer: 16-bit, OC1A = D9, OC1B = D10).
struct Timer1Registers {
  std::uint8_t tccr1a = 0;
  std::uint8_t tccr1b = 0;
  std::uint16_t tcnt1 = 0;
  std::uint16_t ocr1a = 0;
  std::uint16_t ocr1b = 0;
  std::uint16_t icr1 = 0;
};

/// One access of the firmware to a watched I/O register (`VirtualUno::watch_io`).
struct IoAccess {
  std::uint64_t cycle = 0;  ///< CPU cycle at which the accessing instruction started (exact)
  std::uint8_t value = 0;   ///< the byte written, or the byte the read returned
  bool write = false;       ///< true for a write (OUT/STS), false for a read (IN/LDS)
};

/// A symbol of the firmware image's ELF symbol table (`VirtualUno::symbol`).
struct FirmwareSymbol {
  /// Which memory the address is in (avr-gcc's ELF puts data at 0x800000 and EEPROM at 0x810000).
  enum class Space { flash, data, eeprom };
  Space space = Space::flash;  ///< Memory of the symbol.
  std::uint32_t address = 0;   ///< Address inside that memory (data: what `read_memory` takes).
  std::uint32_t size = 0;      ///< Size in bytes as the ELF records it (0 for labels).
};

/// Counters of one board.
struct VirtualUnoStats {
  std::uint64_t boots = 0;                     ///< resets of any kind, the first power-on included
  std::uint64_t firmware_watchdog_resets = 0;  ///< reboots through simavr's watchdog (not injected)
  std::uint64_t injected_watchdog_resets = 0;
  std::uint64_t injected_external_resets = 0;
  std::uint64_t power_cycles = 0;
  std::uint64_t port_open_resets = 0;          ///< resets by `reset_on_open` (also in injected_external_resets)
  std::uint64_t rx_bytes = 0;        ///< bytes that entered the UART (after to_mcu faults)
  std::uint64_t rx_bytes_lost = 0;   ///< bytes that arrived while the receiver was disabled or off
  std::uint64_t tx_bytes = 0;        ///< bytes the firmware wrote to UDR0 (before from_mcu faults)
  std::uint64_t host_bytes_discarded = 0;  ///< read-buffer / pty overflow
  /// CPU cycles spent executing: not asleep (idle sleep until an interrupt), powered off or halted. The
  /// firmware's CPU load (`tether bench`'s device CPU per operation), where `cycles()` is only time.
  std::uint64_t awake_cycles = 0;
  FaultCounts to_mcu;    ///< what the to_mcu fault model did
  FaultCounts from_mcu;  ///< what the from_mcu fault model did
};

class VirtualUnoGroup;

/// One simulated Arduino Uno. Not copyable or movable. Thread-safe unless a member says otherwise.
class VirtualUno {
 public:
  using OutputHandler = std::function<void(const std::uint8_t* data, std::size_t size)>;

  /// Loads the image and creates the MCU (not running yet). Throws std::system_error: the OS error
  /// for a missing or unreadable file, VirtualUnoError for a bad image; the message names the file.
  explicit VirtualUno(VirtualUnoOptions options);
  /// Non-throwing entry point: nullptr and `error` set on failure; `message` (if given) gets the text.
  static std::unique_ptr<VirtualUno> create(VirtualUnoOptions options, std::error_code& error,
                                            std::string* message = nullptr) noexcept;
  /// Stops (the whole group, if the board is in a running one) and releases everything.
  ~VirtualUno();
  VirtualUno(const VirtualUno&) = delete;
  VirtualUno& operator=(const VirtualUno&) = delete;

  // --- lifecycle ---------------------------------------------------------------------------------------
  /// Runs the board on its own thread with `options().pacing`. Throws std::logic_error if it is a member
  /// of a VirtualUnoGroup, std::system_error if the thread cannot start. No-op when already running.
  void start();
  /// Stops the simulation thread (of the whole group, for a member) and closes the pty. The simulated
  /// state is kept: `start()` continues where it stopped. No-op when not running.
  void stop();
  bool running() const;
  /// Advances the simulation by `duration` on the calling thread (which is the simulation thread for
  /// the call), as fast as possible. For a group member this advances the whole group. Throws
  /// std::logic_error while a thread runs the board.
  void run_for(SimDuration duration);

  // --- byte stream --------------------------------------------------------------------------------------
  /// Queues bytes for the MCU's RX (never blocks; taken at the next quantum boundary).
  void write(std::span<const std::uint8_t> bytes);
  void write(std::string_view text);
  /// Copies up to buffer.size() received bytes; waits up to `timeout` for the first one. Returns the
  /// count, 0 on timeout. Only sees bytes while neither a pty nor an output handler takes them.
  std::size_t read(std::span<std::uint8_t> buffer, std::chrono::milliseconds timeout);
  /// Bytes waiting in the read buffer.
  std::size_t available() const;
  /// Sets (or clears, with an empty function) the output handler. See the file comment for the contract.
  void set_output_handler(OutputHandler handler);

  // --- pseudo-terminal ---------------------------------------------------------------------------------
  /// Opens a pty bridged to UART0 and returns its slave path (e.g. /dev/pts/7). The pty is raw from the
  /// start and stays usable while clients come and go; it is closed by `stop()`. Opening it before
  /// `start()` captures the boot output. Returns the existing path if one is open.
  std::string open_pty();
  std::string open_pty(std::error_code& error);
  /// The slave path while a pty is open.
  std::optional<std::string> pty_path() const;

  // --- time --------------------------------------------------------------------------------------------
  std::uint64_t cycles() const;
  SimDuration simulated_time() const;
  std::uint32_t frequency_hz() const;
  /// Cycles for a simulated duration at this board's clock (rounded down).
  std::uint64_t to_cycles(SimDuration duration) const;
  SimDuration to_duration(std::uint64_t cycles) const;

  // --- faults --------------------------------------------------------------------------------------------
  /// Changes one direction's faults (counts and PRNG state are kept). Throws std::invalid_argument.
  void set_faults(Direction direction, const FaultConfig& config);
  /// Resets the MCU at the next quantum boundary.
  void reset(ResetKind kind, SimDuration off_for = {});
  /// Resets the MCU when simulated time reaches `at` (at once if it already has). `off_for` is the power-off
  /// time of a power cycle.
  void schedule_reset(ResetKind kind, SimDuration at, SimDuration off_for = {});
  VirtualUnoStats stats() const;

  // --- pins, registers, peripherals -------------------------------------------------------------------
  /// Throws std::out_of_range for a pin outside 0..19.
  PinState pin(int arduino_pin) const;
  bool digital_level(int arduino_pin) const;
  /// Port 'B', 'C' or 'D' (std::out_of_range otherwise).
  PortRegisters port(char name) const;
  /// Drives an input pin from outside (a button, a sensor): sets PINx and raises pin-change interrupts.
  void set_input_level(int arduino_pin, bool level);
  /// Stops driving a pin from outside.
  void release_input(int arduino_pin);
  /// The voltage the ADC reads on channel 0..7 (A0..A5 are 0..5). AVcc = AREF = 5 V.
  void set_analog_input(int channel, double volts);
  PulseTiming pulse_timing(int arduino_pin) const;
  Timer1Registers timer1() const;
  UartStatus uart() const;
  CpuState cpu_state() const;
  /// Raw data-space contents (registers, I/O, SRAM: 0 .. 0x8FF), no side effects.
  std::vector<std::uint8_t> read_memory(std::uint16_t address, std::size_t length) const;
  /// Overwrites data-space bytes (e.g. markers in free SRAM), no side effects.
  void write_memory(std::uint16_t address, std::span<const std::uint8_t> bytes);
  /// Overwrites EEPROM bytes (0 .. kEepromSize-1) through simavr's EEPROM ioctl, as a programmer would:
  /// the firmware reads them at its next EEPROM access. EEPROM survives every kind of reset and power
  /// cycle (it starts erased, 0xFF, or with the image's .eeprom section). Throws std::out_of_range.
  void write_eeprom(std::uint16_t address, std::span<const std::uint8_t> bytes);
  /// Copies `length` EEPROM bytes from `address` (what the firmware wrote included). Throws
  /// std::out_of_range.
  std::vector<std::uint8_t> read_eeprom(std::uint16_t address, std::size_t length) const;
  /// Looks `name` up in the image's ELF symbol table (read when the board was created): where a firmware
  /// global lives, so a test reads it with `read_memory` without hard-coding an address that moves with
  /// every build. C++ names are mangled: give the variable C linkage (`extern "C"`). A global symbol wins
  /// over local ones of the same name; nullopt when there is none.
  std::optional<FirmwareSymbol> symbol(std::string_view name) const;
  /// Reads / writes an I/O register the way the CPU would (peripheral side effects included: e.g. reading
  /// ADCL returns a conversion, writing ADCSRA starts one). For tests and tools poking peripherals.
  std::uint8_t io_read(std::uint16_t address);
  void io_write(std::uint16_t address, std::uint8_t value);
  /// Records every firmware read and write of the I/O register at `address` (0x20..0xFF, SREG excluded)
  /// with its exact cycle, keeping the first `limit` accesses (later ones are counted, not kept): cycle
  /// counts between two marker writes (e.g. to GPIOR0, which no peripheral uses), or from reading a UDR0
  /// byte to writing the next. The register's own behaviour (the UART's FIFO, flags) is unchanged.
  /// Watching an address again clears its record. Throws std::out_of_range.
  void watch_io(std::uint16_t address, std::size_t limit = std::size_t{1} << 16);
  /// The accesses recorded since `watch_io(address)` (empty when it is not watched).
  std::vector<IoAccess> io_accesses(std::uint16_t address) const;
  /// Accesses to a watched register that did not fit its `limit`.
  std::uint64_t io_accesses_dropped(std::uint16_t address) const;

  const VirtualUnoOptions& options() const;

  struct Impl;

 private:
  friend class VirtualUnoGroup;
  std::unique_ptr<Impl> impl_;
};

/// Several boards advancing in lockstep on one thread, with UARTs wired between them. The group does not
/// own its members; a member must not be destroyed while the group runs (its destructor stops the group).
/// Destroy boards and groups from one thread.
class VirtualUnoGroup {
 public:
  /// `quantum` is also the latency of every board-to-board link (keep it below a byte time: 64 us is
  /// ~0.7 bytes at 115200).
  explicit VirtualUnoGroup(Pacing pacing = Pacing::real_time, SimDuration quantum = std::chrono::microseconds(64));
  ~VirtualUnoGroup();
  VirtualUnoGroup(const VirtualUnoGroup&) = delete;
  VirtualUnoGroup& operator=(const VirtualUnoGroup&) = delete;

  /// Adds a board that has never run and is in no group (std::logic_error otherwise). All members must
  /// share the clock frequency.
  void add(VirtualUno& board);
  /// Wires `from`'s TX to `to`'s RX (both members; `from == to` is a loopback). A TX drives one RX and an
  /// RX listens to one TX (std::logic_error otherwise); host writes still merge into `to`'s RX, and
  /// `from` no longer delivers to the host. Only while stopped.
  void connect(VirtualUno& from, VirtualUno& to);
  void start();
  void stop();
  bool running() const;
  /// Advances every member by `duration` on the calling thread (std::logic_error while running).
  void run_for(SimDuration duration);
  SimDuration quantum() const;
  Pacing pacing() const;

  struct Impl;

 private:
  friend class VirtualUno;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tether::transports

template <>
struct std::is_error_code_enum<tether::transports::VirtualUnoError> : std::true_type {};
