# APM 2.5 flight board: ATmega2560 at 16 MHz, avr-gcc 5.4 from Debian (gcc-avr, avr-libc).
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR avr)
set(CMAKE_C_COMPILER avr-gcc)
set(CMAKE_CXX_COMPILER avr-g++)
set(CMAKE_ASM_COMPILER avr-gcc)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(QUAD_TARGET avr CACHE STRING "" FORCE)
set(QUAD_MCU atmega2560)
set(QUAD_F_CPU 16000000UL)

# Code size and speed (docs/targets.md, "Memory": the compiler options, each measured on the flight
# image's flash and its PIL iterations):
#   -mrelax           the linker shortens calls and jumps within reach (rcall/rjmp: 2 bytes, 1 cycle less)
#   -mstrict-X        no X-pointer arithmetic the AVR cannot do in one instruction
#   -flto             the image optimised as a whole (small functions inlined across files, constants
#                     propagated into their one caller); the two --param keep inlining from merging
#                     stack frames, so the peak stack does not grow with it; one partition: the
#                     whole image in one unit (smaller, and no constants duplicated in each unit's data)
# Not -mcall-prologues (one shared register save/restore instead of one per function): 7 KB less flash,
# but the shared routine costs about 600 cycles of the median 200 Hz iteration.
set(_flags "-mmcu=${QUAD_MCU} -DF_CPU=${QUAD_F_CPU} -DQUAD_TARGET_AVR=1 -Os -ffunction-sections -fdata-sections \
-mrelax -mstrict-X -flto -flto-partition=one --param large-stack-frame=64 --param large-stack-frame-growth=20")
set(CMAKE_C_FLAGS_INIT "${_flags}")
set(CMAKE_CXX_FLAGS_INIT "${_flags} -fno-exceptions -fno-rtti -fno-threadsafe-statics")
set(CMAKE_ASM_FLAGS_INIT "-mmcu=${QUAD_MCU}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-mmcu=${QUAD_MCU} -Wl,--gc-sections -Wl,--relax")
# Link-time optimisation: the static libraries hold GCC's intermediate code, archived and indexed by the
# wrappers that load GCC's plugin.
set(CMAKE_AR avr-gcc-ar CACHE FILEPATH "")
set(CMAKE_RANLIB avr-gcc-ranlib CACHE FILEPATH "")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
