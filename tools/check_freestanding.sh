#!/usr/bin/env bash
# The freestanding rule, checked on compiled code: the flight core's static libraries must not
# reference the heap, exceptions, RTTI, the C++ standard library, or double-precision libm, and must not
# define vtables (virtual dispatch costs SRAM on the AVR). Usage: check_freestanding.sh LIB.a...
set -u
[ $# -gt 0 ] || { echo "usage: $0 LIB.a..." >&2; exit 2; }

forbidden_undefined='^(malloc|calloc|realloc|free|_Znw[jm]|_Zna[jm]|_Zdl|_Zda|__cxa_throw|__cxa_allocate_exception|__cxa_begin_catch|__gxx_personality_v0|__cxa_guard_acquire|__dynamic_cast|_ZTI.*|_ZNSt.*|_ZSt.*|sin|cos|tan|asin|acos|atan|atan2|sqrt|exp|log|pow|fabs|floor|ceil|fmod|tanh|sinh|cosh)$'
forbidden_defined='^(_ZTV|_ZTI|_ZTS)'

status=0
for lib in "$@"; do
  if [ ! -f "$lib" ]; then
    echo "FAIL: $lib: no such library (build first)" >&2
    status=1
    continue
  fi
  bad_u=$(nm -g --undefined-only "$lib" 2>/dev/null | awk '{print $NF}' | grep -E "$forbidden_undefined" | sort -u)
  bad_d=$(nm -g --defined-only "$lib" 2>/dev/null | awk '{print $NF}' | grep -E "$forbidden_defined" | sort -u)
  if [ -n "$bad_u$bad_d" ]; then
    echo "FAIL: $(basename "$lib") breaks the freestanding rule:"
    for s in $bad_u; do echo "  references $s ($(echo "$s" | c++filt))"; done
    for s in $bad_d; do echo "  defines $s ($(echo "$s" | c++filt))"; done
    status=1
  else
    echo "ok: $(basename "$lib")"
  fi
done
exit $status
