# Runs the Cortex-M EKF instruction-count image on QEMU with -icount shift=0 (ctest
# cortexm_ekf_instruction_count) and checks: the calibration loops read their exact instruction counts
# (+-1 SysTick tick = 40), the EKF fused fixes and stayed finite, and its iteration that fuses a fix
# (the mean and the largest over 4 s) is within BUDGET instructions.
#   cmake -DQEMU=<qemu-system-arm> -DIMAGE=<mps2_ekf_instruction_count.elf> -DBUDGET=<instructions> -P ...
set(CHECK_NAME check_ekf_instruction_count.cmake)
include("${CMAKE_CURRENT_LIST_DIR}/instruction_count_run.cmake")
figure(ekf_state_ok "${out}")
if(NOT value EQUAL 1)
  list(APPEND failures "the EKF did not set its position from the fixes or is not finite")
endif()
figure(ekf_fixes_fused_in_measurement "${out}")
if(value LESS 50)
  list(APPEND failures "only ${value} iterations fused a fix: the measurement did not exercise the fusion")
endif()
check_within_budget(ekf_iteration_predict_with_fix ekf_iteration_predict_with_fix_max)
report_failures("Cortex-M EKF instruction count")
