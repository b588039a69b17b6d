# Warnings as errors on our own targets only (third-party headers come in as SYSTEM includes). The fuzz build
# (bench/fuzz.sh, clang) turns -Werror off with -DCAIRN_WERROR=OFF: clang warns about things gcc does not,
# and a warning must not keep the harnesses from running.
option(CAIRN_WERROR "Treat warnings as errors on Cairn's targets" ON)
function(cairn_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(CAIRN_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
