# The freestanding rule, enforced by the build.
#
# The flight core (math, link codec, estimation, control, firmware application) must compile unchanged
# with avr-g++ 5.4 (-std=gnu++14), arm-none-eabi-g++ and the host g++: no heap, no exceptions, no RTTI,
# no C++ standard library, no virtual dispatch, float only. quad_core_library() applies the flags that
# turn each of those into a compile error, and registers the library for the symbol check
# (tools/check_freestanding.sh, run by ctest) that catches what flags cannot (calls to malloc/new,
# vtables, typeinfo, double-precision libm calls).

set(QUAD_CORE_LIBRARIES "" CACHE INTERNAL "freestanding core libraries")

function(quad_core_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  if(ARG_SOURCES)
    add_library(${name} STATIC ${ARG_SOURCES})
    set(scope PUBLIC)
    set(private PRIVATE)
  else()
    add_library(${name} INTERFACE)
    set(scope INTERFACE)
    set(private INTERFACE)
  endif()
  target_include_directories(${name} ${scope} "${CMAKE_CURRENT_SOURCE_DIR}/include")
  if(ARG_DEPS)
    target_link_libraries(${name} ${scope} ${ARG_DEPS})
  endif()
  if(ARG_SOURCES)
    # -nostdinc++ removes the C++ library headers: <vector>, <cmath>, <new> fail to compile, while the
    # C headers every target has (<math.h>, <stdint.h>, <stddef.h>, <string.h>) stay available.
    target_compile_options(${name} PRIVATE -fno-exceptions -fno-rtti -nostdinc++
                           -Wall -Wextra -Werror -Wshadow -Wfloat-conversion)
    # float only: any silent promotion to double is an error. Not on the AVR, where avr-libc's sinf()
    # and friends are macros for the double functions and double is itself 32 bits wide.
    if(NOT QUAD_TARGET STREQUAL "avr")
      target_compile_options(${name} PRIVATE -Wdouble-promotion)
    endif()
    if(QUAD_TARGET STREQUAL "host")
      set_target_properties(${name} PROPERTIES CXX_STANDARD 17 POSITION_INDEPENDENT_CODE ON)
    else()
      set_target_properties(${name} PROPERTIES CXX_STANDARD 14 CXX_EXTENSIONS ON)
    endif()
    set(QUAD_CORE_LIBRARIES "${QUAD_CORE_LIBRARIES};${name}" CACHE INTERNAL "")
  endif()
endfunction()

# Cross images: print flash and RAM use after linking and enforce the target's budget.
function(quad_firmware_image target)
  if(QUAD_TARGET STREQUAL "avr")
    set(objcopy avr-objcopy)
    set(size_tool avr-size)
    # The AVR budget (docs/targets.md, "Budgets"): 128 KiB of program flash, all below the 128 KiB word
    # boundary (no EIND trampolines), the upper half left to the bootloader and growth; 7 KiB of the 8 KiB
    # SRAM for data, bss and the stack together (the PIL tests add the measured peak stack).
    set(flash_limit 131072)
    set(ram_limit 7168)
  elseif(QUAD_TARGET STREQUAL "cortex-m4")
    set(objcopy arm-none-eabi-objcopy)
    set(size_tool arm-none-eabi-size)
    set(flash_limit 4194304)
    set(ram_limit 4194304)
  else()
    return()
  endif()
  set_target_properties(${target} PROPERTIES SUFFIX ".elf")
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND ${objcopy} -O ihex -R .eeprom $<TARGET_FILE:${target}> $<TARGET_FILE_DIR:${target}>/${target}.hex
    COMMAND ${CMAKE_COMMAND} -DSIZE_TOOL=${size_tool} -DELF=$<TARGET_FILE:${target}>
            -DFLASH_LIMIT=${flash_limit} -DRAM_LIMIT=${ram_limit}
            -P ${PROJECT_SOURCE_DIR}/cmake/CheckImageSize.cmake
    VERBATIM)
endfunction()
