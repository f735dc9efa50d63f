# Runs the cycle bench on simavr and fails when a figure exceeds its budget (ctest avr_cycle_bench).
#   cmake -DAVR_CYCLES=<tool> -DIMAGE=<cycle_bench.elf> -DWORST_BUDGET=<cycles> -DTYPICAL_BUDGET=<cycles>
#         -DTICK_BUDGET=<cycles> -DRAM_BUDGET=<bytes> -P check_cycle_budget.cmake
# WORST_BUDGET and TYPICAL_BUDGET bound iteration_worst / iteration_typical, the 100 Hz loop's single-rate
# iteration (every stage in one); TICK_BUDGET bounds every iteration of the 400 Hz loop (sections
# tick400_*, typical and worst frame): 40 000, one 400 Hz period at 16 MHz.
# The bench reports each stage; a section named "check_failed:..." means a scenario did not take the
# branches it claims (e.g. the vision fix was not fused), which also fails the test.
foreach(var AVR_CYCLES IMAGE WORST_BUDGET TYPICAL_BUDGET TICK_BUDGET RAM_BUDGET)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_cycle_budget.cmake: ${var} is not set")
  endif()
endforeach()
if(NOT EXISTS "${IMAGE}")
  message(FATAL_ERROR "check_cycle_budget.cmake: ${IMAGE} does not exist (build the avr-apm25 preset's cycle_bench)")
endif()

execute_process(COMMAND "${AVR_CYCLES}" "${IMAGE}" --json
                RESULT_VARIABLE rc OUTPUT_VARIABLE json ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "avr_cycles failed (${rc}): ${err}")
endif()
# simavr's loader prints its own lines first: the report is the last line.
string(REGEX MATCH "{[^\n]*}" json "${json}")
execute_process(COMMAND "${AVR_CYCLES}" "${IMAGE}" OUTPUT_VARIABLE table)
message(STATUS "\n${table}")

string(JSON sections GET "${json}" sections)
string(JSON count LENGTH "${sections}")
math(EXPR last "${count} - 1")
# One pass over the sections: a failed scenario check stops here; of the 400 Hz frames' iterations the
# largest of each frame is kept.
foreach(frame typical worst)
  set(largest_${frame} 0)
  set(largest_name_${frame} "")
endforeach()
foreach(i RANGE ${last})
  string(JSON name MEMBER "${sections}" ${i})
  if(name MATCHES "^check_failed:")
    message(FATAL_ERROR "cycle bench scenario check failed: ${name}")
  elseif(name MATCHES "^tick400_(typical|worst)_")
    set(frame ${CMAKE_MATCH_1})
    string(JSON cycles GET "${sections}" ${name})
    if(cycles GREATER largest_${frame})
      set(largest_${frame} ${cycles})
      set(largest_name_${frame} ${name})
    endif()
  endif()
endforeach()

set(failed "")
foreach(pair "iteration_worst;${WORST_BUDGET}" "iteration_typical;${TYPICAL_BUDGET}")
  list(GET pair 0 name)
  list(GET pair 1 budget)
  string(JSON cycles ERROR_VARIABLE missing GET "${sections}" ${name})
  if(missing)
    message(FATAL_ERROR "cycle bench reported no section ${name}")
  endif()
  if(cycles GREATER budget)
    string(APPEND failed "${name}: ${cycles} cycles > budget ${budget}\n")
  else()
    message(STATUS "${name}: ${cycles} cycles <= budget ${budget}")
  endif()
endforeach()

# Every iteration of the 400 Hz loop's frames within the budget (the largest of each frame reported).
foreach(frame typical worst)
  if(largest_name_${frame} STREQUAL "")
    message(FATAL_ERROR "cycle bench reported no tick400_${frame}_* section")
  endif()
  if(largest_${frame} GREATER TICK_BUDGET)
    string(APPEND failed "400 Hz ${frame} frame: ${largest_name_${frame}} ${largest_${frame}} cycles > budget ${TICK_BUDGET}\n")
  else()
    message(STATUS "400 Hz ${frame} frame: largest iteration ${largest_name_${frame}} ${largest_${frame}} cycles <= budget ${TICK_BUDGET}")
  endif()
endforeach()

string(JSON static_ram GET "${json}" static_ram)
string(JSON peak_stack GET "${json}" peak_stack)
math(EXPR ram "${static_ram} + ${peak_stack}")
if(ram GREATER RAM_BUDGET)
  string(APPEND failed "data + bss + peak stack: ${ram} bytes > budget ${RAM_BUDGET}\n")
else()
  message(STATUS "data + bss + peak stack: ${ram} bytes <= budget ${RAM_BUDGET}")
endif()
if(failed)
  message(FATAL_ERROR "${failed}")
endif()
