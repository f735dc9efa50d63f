# Processor-in-the-loop hover (ctest pil_hover_*): flies SCENARIO once with the host firmware and once
# with FIRMWARE (an emulated processor running the cross image), same seed, and checks the emulated
# flight: complete, no crash, take-off (altitude reached), hold (settled in the band), the scenario's
# firmware parameters applied, and horizontal standard deviation over the hold within MAX_STD_RATIO of
# the host firmware's.
#   cmake -DQUAD_SIM=<quad_sim> -DFIRMWARE=<command> -DSCENARIO=<yaml> -DOUT=<dir> -DMAX_STD_RATIO=<r>
#         [-DRAM_BUDGET=<bytes> -DSIZE_TOOL=<avr-size> -DIMAGE=<elf>] [-DPERIOD_CYCLES=<cycles> [-DPERIOD_SCOPE=flown]]
#         [-DLOG_CHECK=<command>] -P pil_hover.cmake
foreach(var QUAD_SIM FIRMWARE SCENARIO OUT MAX_STD_RATIO)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "pil_hover.cmake: ${var} is not set")
  endif()
endforeach()

function(fly name firmware_args)
  file(REMOVE_RECURSE "${OUT}/${name}")
  execute_process(COMMAND "${QUAD_SIM}" --scenario "${SCENARIO}" --out "${OUT}/${name}" --no-plots --quiet
                          ${firmware_args}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT EXISTS "${OUT}/${name}/summary.json")
    message(FATAL_ERROR "${name}: quad_sim wrote no summary (exit ${rc}): ${out}${err}")
  endif()
  file(READ "${OUT}/${name}/summary.json" json)
  set(${name}_json "${json}" PARENT_SCOPE)
endfunction()

function(get_number json out)
  string(JSON value ERROR_VARIABLE error GET "${json}" ${ARGN})
  if(error OR value STREQUAL "null" OR value STREQUAL "")
    set(${out} "" PARENT_SCOPE)
  else()
    set(${out} "${value}" PARENT_SCOPE)
  endif()
endfunction()

fly(host "")
fly(target "--firmware;${FIRMWARE}")

set(failures "")
foreach(run host target)
  string(JSON complete GET "${${run}_json}" complete)
  string(JSON crashed GET "${${run}_json}" crashed)
  get_number("${${run}_json}" reached altitude_reached_s)
  get_number("${${run}_json}" settled settling_time_s)
  get_number("${${run}_json}" std hold horizontal std_2d)
  get_number("${${run}_json}" est_rms estimate_vs_truth horizontal_rms_m)
  set(${run}_std "${std}")
  message(STATUS "${run}: complete ${complete}, crashed ${crashed}, altitude reached at ${reached} s, "
                 "settled after ${settled} s, horizontal std ${std} m, estimate horizontal rms ${est_rms} m")
  if(NOT complete)
    string(JSON reason GET "${${run}_json}" reason)
    list(APPEND failures "${run}: run not complete (${reason}; see ${OUT}/${run}/firmware.log)")
  endif()
  if(crashed)
    list(APPEND failures "${run}: crashed")
  endif()
  if(reached STREQUAL "")
    list(APPEND failures "${run}: never took off to the setpoint altitude")
  endif()
  if(settled STREQUAL "")
    list(APPEND failures "${run}: never settled in the hold band")
  endif()
  if(std STREQUAL "")
    list(APPEND failures "${run}: no hold statistics")
  endif()
  # A scenario that downloads the flight's log over the radio (log_download): on the emulated board it
  # completed, and what came is a ULog (its 7-byte magic). The host firmware paces LOG_DATA on the wall
  # clock, which a lockstep flight outruns (docs/logging.md): its download is reported, not checked.
  string(JSON download ERROR_VARIABLE no_download GET "${${run}_json}" log_download)
  if(NOT no_download AND run STREQUAL "target")
    string(JSON download_complete GET "${download}" complete)
    get_number("${download}" download_bytes bytes_received)
    get_number("${download}" download_rate rate_bytes_s)
    message(STATUS "${run}: log download complete ${download_complete}, ${download_bytes} bytes, ${download_rate} bytes/s")
    file(READ "${OUT}/${run}/log_download.ulg" magic LIMIT 7 HEX)
    if(NOT download_complete OR NOT magic STREQUAL "554c6f67011235")
      list(APPEND failures "${run}: the log download over the radio failed (complete ${download_complete}, starts with ${magic})")
    endif()
  endif()
endforeach()

# The scenario's firmware parameters must reach the emulated firmware as they reach quad_firmware.
file(READ "${SCENARIO}" scenario_text)
file(READ "${OUT}/target/events.log" target_events)
if(scenario_text MATCHES "\nfirmware_params:" AND target_events MATCHES "params: store empty")
  list(APPEND failures "target: the scenario's firmware_params did not reach the firmware (store empty)")
endif()
if(target_events MATCHES "params rejected|params: store corrupt|params: table changed")
  list(APPEND failures "target: its parameter store was not accepted (see ${OUT}/target/events.log)")
endif()

if(NOT host_std STREQUAL "" AND NOT target_std STREQUAL "")
  # CMake has no floating-point arithmetic: compare in micrometres (awk does the conversion).
  foreach(v host_std target_std)
    execute_process(COMMAND awk "BEGIN { printf \"%d\", ${${v}} * 1e6 + 0.5 }" OUTPUT_VARIABLE ${v}_um)
  endforeach()
  execute_process(COMMAND awk "BEGIN { printf \"%d\", ${host_std_um} * ${MAX_STD_RATIO} + 0.5 }" OUTPUT_VARIABLE bound_um)
  message(STATUS "horizontal std: target ${target_std_um} um, host ${host_std_um} um, bound ${bound_um} um "
                 "(${MAX_STD_RATIO} x host)")
  if(target_std_um GREATER bound_um)
    list(APPEND failures "horizontal std ${target_std_um} um exceeds ${MAX_STD_RATIO} x the host's ${host_std_um} um")
  endif()
endif()

# Optional (AVR): data + bss + the peak stack avr_pil saw over the flight within RAM_BUDGET bytes.
if(DEFINED RAM_BUDGET)
  file(READ "${OUT}/target/firmware.log" log)
  string(REGEX MATCH "peak stack ([0-9]+) bytes" found "${log}")
  set(stack "${CMAKE_MATCH_1}")
  execute_process(COMMAND "${SIZE_TOOL}" "${IMAGE}" OUTPUT_VARIABLE sizes)
  string(REGEX MATCH "\n *[0-9]+[ \t]+([0-9]+)[ \t]+([0-9]+)" found_sizes "${sizes}")
  set(data "${CMAKE_MATCH_1}")
  set(bss "${CMAKE_MATCH_2}")
  if(stack STREQUAL "" OR data STREQUAL "")
    list(APPEND failures "no peak stack in ${OUT}/target/firmware.log or no sizes from ${SIZE_TOOL}")
  else()
    math(EXPR ram "${data} + ${bss} + ${stack}")
    message(STATUS "RAM: data ${data} + bss ${bss} + peak stack ${stack} = ${ram} bytes (budget ${RAM_BUDGET})")
    if(ram GREATER RAM_BUDGET)
      list(APPEND failures "RAM ${ram} bytes exceeds ${RAM_BUDGET}")
    endif()
  endif()
endif()

# Optional (AVR): the firmware's own iteration, timed to the cycle by avr_pil (hal::TracePoint marks):
# printed for the record, and each period's work (the whole iteration, telemetry and a fix step inside it
# included, plus any vision fix fused on arrival before the next iteration) must fit the control period.
if(DEFINED PERIOD_CYCLES)
  file(READ "${OUT}/target/firmware.log" log)
  string(REGEX MATCHALL "avr_pil: (cycles|overruns) of [^\n]*" profile "${log}")
  foreach(line ${profile})
    message(STATUS "${line}")
  endforeach()
  # PERIOD_SCOPE flown: only the periods that flew the vehicle must fit (above 100 Hz the end of the boot
  # calibration, one iteration on the ground before arming, takes longer than a period).
  if(PERIOD_SCOPE STREQUAL "flown")
    set(scope "iteration and fixes after it flown")
  else()
    set(scope "iteration and fixes after it")
  endif()
  string(REGEX MATCH "cycles of ${scope}: [0-9]+ samples, median [0-9]+, p99 [0-9]+, max ([0-9]+)" found "${log}")
  set(work_max "${CMAKE_MATCH_1}")
  if(work_max STREQUAL "")
    list(APPEND failures "no iteration profile in ${OUT}/target/firmware.log (hal::trace not wired?)")
  elseif(work_max GREATER PERIOD_CYCLES)
    list(APPEND failures "the longest ${scope} took ${work_max} cycles, more than the ${PERIOD_CYCLES} of a control period")
  else()
    math(EXPR share "100 * ${work_max} / ${PERIOD_CYCLES}")
    message(STATUS "longest ${scope}: ${work_max} cycles, ${share} % of the ${PERIOD_CYCLES}-cycle period")
  endif()
endif()

# Optional: the flight log (LOG_CHECK: a command, given the target's run folder and the DataFlash image
# avr_pil wrote there, FIRMWARE having --dataflash <OUT>/target/dataflash.img).
if(DEFINED LOG_CHECK)
  execute_process(COMMAND ${LOG_CHECK} "${OUT}/target" "${OUT}/target/dataflash.img"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message(STATUS "flight log:\n${out}${err}")
  if(NOT rc EQUAL 0)
    list(APPEND failures "the flight log check failed (see above)")
  endif()
endif()

if(failures)
  string(REPLACE ";" "\n  " failures "${failures}")
  message(FATAL_ERROR "processor-in-the-loop hover failed:\n  ${failures}")
endif()
