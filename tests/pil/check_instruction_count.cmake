# Runs the Cortex-M instruction-count image on QEMU with -icount shift=0 (ctest cortexm_instruction_count)
# and checks: the calibration loops read their exact instruction counts (+-1 SysTick tick = 40), the
# worst case took the branches it claims (saturated), and every whole-iteration figure is within BUDGET.
#   cmake -DQEMU=<qemu-system-arm> -DIMAGE=<mps2_instruction_count.elf> -DBUDGET=<instructions> -P ...
set(CHECK_NAME check_instruction_count.cmake)
include("${CMAKE_CURRENT_LIST_DIR}/instruction_count_run.cmake")
figure(worst_case_saturated "${out}")
if(NOT value EQUAL 1)
  list(APPEND failures "the worst case did not saturate tilt and yaw as it claims")
endif()
check_within_budget(iteration_typical iteration_with_mag iteration_with_mag_and_fix iteration_worst)
report_failures("Cortex-M instruction count")
