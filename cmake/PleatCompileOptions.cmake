# Warning, floating-point and sanitizer flags shared by every Pleat target.
function(pleat_set_warnings target)
  if(CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wstrict-prototypes
      $<$<BOOL:${PLEAT_WERROR}>:-Werror>)
  elseif(MSVC)
    target_compile_options(${target} PRIVATE /W4 $<$<BOOL:${PLEAT_WERROR}>:/WX>)
  endif()
  pleat_set_float_semantics(${target})
  pleat_set_sanitizers(${target})
endfunction()

# No floating-point contraction, in every build type: the AVX2 variants are tested bit for bit against the scalar
# kernels, and outputs must not depend on the worker count, which holds only if a*b + c is rounded twice wherever the
# source says so. GCC in its default GNU mode (no -std=c11) contracts into FMA wherever -mfma allows it at -O2 and up,
# and clang contracts within an expression by default, so Release builds differed from the Debug builds CI ran
# (a Release-only difference found in review). Where a kernel wants an FMA it says so (an FMA intrinsic, fmaf).
function(pleat_set_float_semantics target)
  if(CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -ffp-contract=off)
  elseif(MSVC)
    target_compile_options(${target} PRIVATE /fp:precise)
  endif()
endfunction()

# PLEAT_SANITIZE: ASan + UBSan, nothing recoverable (the first finding fails the test). PLEAT_TSAN: ThreadSanitizer
# (scripts/ci-stages.sh runs the "threads" tests with it); the two cannot be combined.
function(pleat_set_sanitizers target)
  if(PLEAT_SANITIZE AND PLEAT_TSAN)
    message(FATAL_ERROR "PLEAT_SANITIZE (ASan) and PLEAT_TSAN cannot be combined")
  endif()
  if(PLEAT_SANITIZE AND CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer
      -fno-sanitize-recover=all)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  elseif(PLEAT_TSAN AND CMAKE_C_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -fsanitize=thread -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=thread)
  endif()
endfunction()
