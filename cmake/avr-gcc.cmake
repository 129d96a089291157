# Toolchain file for the ATmega328P (Arduino Uno) images: avr-gcc 5.4 from Debian's gcc-avr.
# Used by the firmware sub-build that the top-level build drives (see firmware/CMakeLists.txt).
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR avr)
set(CMAKE_C_COMPILER avr-gcc)
set(CMAKE_CXX_COMPILER avr-g++)
set(CMAKE_ASM_COMPILER avr-gcc)
# The gcc-ar wrappers: archives of LTO objects need the linker plugin.
set(CMAKE_AR avr-gcc-ar CACHE FILEPATH "")
set(CMAKE_RANLIB avr-gcc-ranlib CACHE FILEPATH "")
set(AVR_SIZE avr-size)
set(AVR_OBJCOPY avr-objcopy)

set(TETHER_AVR_MCU atmega328p CACHE STRING "AVR part")
set(TETHER_AVR_F_CPU 16000000UL CACHE STRING "CPU clock in Hz")

# No libstdc++, no exceptions, no RTTI, no guarded statics (see docs/portability.md).
set(_avr_common "-mmcu=${TETHER_AVR_MCU} -DF_CPU=${TETHER_AVR_F_CPU} -Os -flto -ffunction-sections -fdata-sections")
set(CMAKE_C_FLAGS_INIT "${_avr_common} -std=gnu11")
set(CMAKE_CXX_FLAGS_INIT "${_avr_common} -std=gnu++14 -fno-exceptions -fno-rtti -fno-threadsafe-statics")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-mmcu=${TETHER_AVR_MCU} -Os -flto -Wl,--gc-sections")

set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
