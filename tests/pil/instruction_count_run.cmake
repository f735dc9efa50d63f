# The common part of the Cortex-M instruction-count checks (check_instruction_count.cmake,
# check_ekf_instruction_count.cmake): QEMU, IMAGE and BUDGET set, the image run on QEMU's mps2-an386 with
# -icount shift=0 (firmware/targets/cortexm/instruction_counter.h), `figure(NAME OUT)` to read a
# "NAME instructions" line into `value`, and `failures` started with the calibration loops' check (their
# exact instruction counts, +-1 SysTick tick = 40); `check_within_budget(NAME...)` and
# `report_failures(TITLE)` to end the check. The including script sets CHECK_NAME first.
foreach(var QEMU IMAGE BUDGET)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "" OR "${${var}}" MATCHES "NOTFOUND$")
    message(FATAL_ERROR "${CHECK_NAME}: ${var} is not set (qemu-system-arm: tools/packages-debian.txt)")
  endif()
endforeach()
execute_process(COMMAND "${QEMU}" -M mps2-an386 -nographic -monitor none -icount shift=0
                        -semihosting-config enable=on,target=native -serial stdio -kernel "${IMAGE}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
message(STATUS "\n${out}")
if(NOT rc EQUAL 0 OR NOT out MATCHES "\ndone\n")
  message(FATAL_ERROR "${CHECK_NAME}: the image did not finish (exit ${rc}): ${err}")
endif()

function(figure name out)
  string(REGEX MATCH "(^|\n)${name} ([0-9]+)\n" line "${out}")
  if(line STREQUAL "")
    message(FATAL_ERROR "no figure '${name}' in the output")
  endif()
  set(value "${CMAKE_MATCH_2}" PARENT_SCOPE)
endfunction()

set(failures "")
foreach(expected 4000 40000)
  figure(calibration_${expected} "${out}")
  math(EXPR error "${value} - ${expected}")
  if(error GREATER 40 OR error LESS -40)
    list(APPEND failures "calibration_${expected} read ${value}: the SysTick/-icount method is off")
  endif()
endforeach()

# Each named figure at most BUDGET instructions.
function(check_within_budget)
  foreach(name ${ARGN})
    figure(${name} "${out}")
    if(value GREATER ${BUDGET})
      list(APPEND failures "${name}: ${value} instructions > ${BUDGET}")
    endif()
  endforeach()
  set(failures "${failures}" PARENT_SCOPE)
endfunction()

# Fails the test with every failure listed under TITLE, one a line.
function(report_failures title)
  if(failures)
    string(REPLACE ";" "\n  " failures "${failures}")
    message(FATAL_ERROR "${title}:\n  ${failures}")
  endif()
endfunction()
